"""A full disk (here: the process's file-size limit, RLIMIT_FSIZE) during ``record`` and ``import``:
one line "disk full at PATH: N frames safely written up to t = ... s", the file readable, no zeroed row,
no segfault, and an import that writes all or nothing."""

from __future__ import annotations

import os
import re
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bootnav.logger.recording import load
from tests.conftest import REPO

pytestmark = pytest.mark.timeout(90)


def _limit(n_bytes: int):
    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG, as on a full disk
        resource.setrlimit(resource.RLIMIT_FSIZE, (n_bytes, resource.RLIM_INFINITY))
    return apply


def _bootnav(*args, limit: int | None = None, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "bootnav", *map(str, args)], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=_limit(limit) if limit else None, **kw)


def test_record_stops_cleanly_when_the_disk_fills(tmp_path):
    link, out = tmp_path / "boot", tmp_path / "rec.h5"
    emu = _bootnav("emulate", "--out-link", link, "--rate", 5000, "--duration", 60, "--quiet", "--write-timeout", 2)
    try:
        end = time.monotonic() + 15
        while not os.path.lexists(link):
            assert time.monotonic() < end and emu.poll() is None, "emulator did not start"
            time.sleep(0.02)
        rec = _bootnav("record", "--port", link, "--out", out, "--quiet", limit=700_000)
        _, err = rec.communicate(timeout=60)
    finally:
        emu.kill()
        emu.communicate()
    assert rec.returncode == 1, err
    # issue 27: the recorder says at start how many minutes fit (a warning line), then the one error line
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("bootnav record: warning: only ")]
    assert "Traceback" not in err and len(lines) == 1, err
    m = re.fullmatch(r"bootnav record: error: disk full at (.+): (\d+) frames safely written up to t = ([\d.]+) s",
                     lines[0])
    assert m and m.group(1) == str(out), err
    rec_ = load(out)  # readable, in this process and by h5py's strict open
    assert rec_.n == int(m.group(2)) > 1000
    assert abs(rec_.t_s[-1] - float(m.group(3))) < 1e-3
    # no zero-filled rows: every frame after the first has a fresh seq, device and host time
    seq = rec_.seq.astype(np.int64)
    assert np.all((np.diff(seq) % 65536) == 1)
    assert np.all(np.diff(rec_.t_device.astype(np.int64)) > 0) and np.all(rec_.t_host > 1e9)
    assert os.path.getsize(out) <= 700_000


def test_import_on_a_full_disk_writes_nothing_and_keeps_the_old_file(tmp_path):
    rng = np.random.default_rng(0)
    n = 60_000
    data = np.column_stack([np.arange(n) / 100, rng.normal(0, 0.1, (n, 2)), 9.81 + rng.normal(0, 0.1, n),
                            rng.normal(0, 0.01, (n, 3))])
    src = tmp_path / "walk.csv"
    with open(src, "w") as f:
        f.write("t,ax,ay,az,gx,gy,gz\n")
        np.savetxt(f, data, delimiter=",", fmt="%.6f")
    out = tmp_path / "walk.h5"
    old = tmp_path / "old.h5"
    small = _bootnav("import", src, "--out", old, "--acc-unit", "mps2", "--gyro-unit", "radps", "--quiet")
    assert small.wait(timeout=60) == 0
    os.replace(old, out)
    before = out.read_bytes()
    proc = _bootnav("import", src, "--out", out, "--force", "--acc-unit", "mps2", "--gyro-unit", "radps",
                    limit=len(before) // 3)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1
    assert err.strip() == f"bootnav import: error: disk full at {out}: 0 frames written (left as it was; an import " \
                          "writes all or nothing)"
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["walk.csv", "walk.h5"]  # no temp file left


def test_no_room_for_a_new_file(tmp_path):
    code = (
        "import sys\n"
        "from bootnav.logger.recording import RecordingWriter, si_channel\n"
        "from bootnav.errors import DiskFullError\n"
        "try:\n"
        "    RecordingWriter(sys.argv[1], si_channel('acc'), si_channel('gyro'))\n"
        "except DiskFullError as exc:\n"
        "    print(exc)\n"
    )
    out = tmp_path / "new.h5"
    proc = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True, cwd=REPO,
                          preexec_fn=_limit(1000), timeout=60)
    assert proc.stdout.strip() == f"disk full at {out}: 0 frames written (no space for a new file)", proc.stderr
    assert "Traceback" not in proc.stderr and proc.returncode == 0
    assert not out.exists()
