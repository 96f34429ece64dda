"""``kill -9`` at 20 random moments of ``import``, ``process`` and ``record``: the input stays byte-identical and
every output is absent, complete, or (a recording) holds every frame up to its last flush.

The moments are drawn (seeded) over the duration of an uninterrupted run, so they fall into start-up, reading,
computing, writing and renaming alike. Each output is checked by ``h5dump`` (when installed) and by a fresh
Python process that reads every dataset. A recording killed while its SWMR writer had it open keeps the
superblock's "open for write" flag: bootnav and h5py read it in SWMR mode, and ``h5dump`` reads it once
``h5clear -s`` has cleared the flag (on a copy here: the recording itself is never changed).
"""

from __future__ import annotations

import hashlib
import json
import os
import select
import shutil
import signal
import subprocess
import sys
import time
import tty
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import REPO, run_python

N_KILLS = 20
H5DUMP, H5CLEAR = shutil.which("h5dump"), shutil.which("h5clear")
pytestmark = pytest.mark.timeout(300)

# one fresh interpreter reads every dataset of every file given; prints {path: {dataset: sha256}} or the error
READ_ALL = (
    "import sys, json, hashlib, h5py, numpy as np\n"
    "out = {}\n"
    "for p in sys.argv[2:]:\n"
    "    try:\n"
    "        d = {}\n"
    "        with h5py.File(p, 'r', swmr=sys.argv[1] == 'swmr') as f:\n"
    "            f.visititems(lambda n, o: d.__setitem__(n, hashlib.sha256(np.ascontiguousarray(o[()]).tobytes())"
    ".hexdigest()) if isinstance(o, h5py.Dataset) else None)\n"
    "        out[p] = d\n"
    "    except Exception as e:\n"
    "        out[p] = 'ERROR ' + repr(e)\n"
    "print(json.dumps(out))\n"
)


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _bootnav(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "bootnav", *args], cwd=REPO, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)


def _run_and_kill(args: list[str], delay_s: float) -> bool:
    """Start ``bootnav ARGS`` and SIGKILL it after ``delay_s``; True if it was killed (not finished)."""
    proc = _bootnav(*args)
    try:
        proc.wait(timeout=delay_s)
        return False
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
        return True
    finally:
        proc.stderr.close()


def _read_all(paths: list[Path], swmr: bool = False) -> dict:
    """{path: {dataset: sha256} or 'ERROR ...'} from one fresh process, and h5dump of each file (``swmr``:
    of a copy whose write flag ``h5clear -s`` cleared)."""
    if not paths:
        return {}
    for p in paths if H5DUMP and (H5CLEAR or not swmr) else []:
        target = p
        if swmr:
            target = p.with_name(p.name + ".cleared")
            shutil.copyfile(p, target)
            subprocess.run([H5CLEAR, "-s", str(target)], check=True, capture_output=True, timeout=60)
        proc = subprocess.run([H5DUMP, "-o", os.devnull, str(target)], capture_output=True, text=True, timeout=60)
        assert proc.returncode == 0, f"h5dump cannot read {p}: {proc.stderr[-300:]}"
    return json.loads(run_python(READ_ALL, "swmr" if swmr else "plain", *map(str, paths)).stdout)


def _timed(args: list[str]) -> float:
    t0 = time.monotonic()
    proc = _bootnav(*args)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()[-2000:]
    return time.monotonic() - t0


def _leftovers(folder: Path, expected: set[str]) -> list[str]:
    """Files other than the expected outputs: only the writers' hidden temporary files are allowed."""
    extra = sorted(p.name for p in folder.iterdir() if p.name not in expected)
    assert all(n.startswith(".") and n.endswith(".tmp") for n in extra), extra
    return extra


def test_kill9_during_import(tmp_path):
    rng = np.random.default_rng(1401)
    n = 80_000  # ~6 MB of CSV: reading, checking and writing each take a good part of the run
    t = np.arange(n) / 200.0
    phase = 2 * np.pi * 1.0 * t
    acc = np.column_stack([8 * np.sin(phase), 0.5 * np.cos(phase), 9.81 + 6 * np.sin(2 * phase)])
    gyro = np.column_stack([0.2 * np.cos(phase), 5 * np.sin(phase), 0.1 * np.sin(3 * phase)])
    src = tmp_path / "walk.csv"
    with open(src, "w") as fh:
        fh.write("t,ax,ay,az,gx,gy,gz\n")
        np.savetxt(fh, np.column_stack([t, acc, gyro]), fmt="%.5f", delimiter=",")
    before = _sha(src)
    units = ["--acc-unit", "mps2", "--gyro-unit", "radps", "--quiet"]
    ref = tmp_path / "ref" / "walk.h5"
    ref.parent.mkdir()
    duration = _timed(["import", str(src), "--out", str(ref), *units])
    outs = []
    for k, delay in enumerate(rng.uniform(0.0, duration, N_KILLS)):
        out_dir = tmp_path / f"k{k}"
        out_dir.mkdir()
        _run_and_kill(["import", str(src), "--out", str(out_dir / "walk.h5"), *units], float(delay))
        assert _sha(src) == before
        _leftovers(out_dir, {"walk.h5"})
        outs += [out_dir / "walk.h5"] if (out_dir / "walk.h5").exists() else []
    read = _read_all([ref, *outs])
    for p in outs:  # all or nothing: a present output is the complete recording
        assert read[str(p)] == read[str(ref)], p


@pytest.mark.slow
def test_kill9_during_process(tmp_path):
    rng = np.random.default_rng(1402)
    src = tmp_path / "walk.h5"
    shutil.copyfile(REPO / "recordings" / "sim_paper-straight.h5", src)
    before = _sha(src)
    ref = tmp_path / "ref"
    args = ["--no-plots", "--quiet"]
    _timed(["process", str(src), "--out", str(ref), *args])  # fills numba's cache: the next run is the real one
    duration = _timed(["process", str(src), "--out", str(ref), "--force", *args])
    names = {"results.h5", "trajectory.csv", "steps.csv", "summary.json"}
    assert {p.name for p in ref.iterdir()} == names
    ref_summary = json.loads((ref / "summary.json").read_text())
    h5s = []
    for k, delay in enumerate(rng.uniform(0.0, duration, N_KILLS)):
        out = tmp_path / f"k{k}"
        _run_and_kill(["process", str(src), "--out", str(out), *args], float(delay))
        assert _sha(src) == before
        if not out.exists():
            continue
        _leftovers(out, names)
        for name in ("trajectory.csv", "steps.csv"):  # absent or complete (byte-identical: deterministic)
            if (out / name).exists():
                assert (out / name).read_bytes() == (ref / name).read_bytes(), (k, name)
        if (out / "summary.json").exists():
            assert json.loads((out / "summary.json").read_text()).keys() == ref_summary.keys()
        h5s += [out / "results.h5"] if (out / "results.h5").exists() else []
    read = _read_all([ref / "results.h5", *h5s])
    for p in h5s:
        assert read[str(p)] == read[str(ref / "results.h5")], p


RATE = 500  # frames/s sent on the pty (header: dlpf 3, smplrt_div 1)
FLUSH_S = 0.2
LATENCY_S = 0.5  # read + parse + write delay allowed on a loaded 2-core machine (0.03 s seen)


def _frames(n: int) -> bytes:
    from bootnav.logger.protocol import pack_samples

    seq = np.arange(n)
    acc = np.column_stack([seq % 1000 - 500, np.zeros(n), np.full(n, 2048)]).astype(np.int16)
    return pack_samples(seq, seq * (1_000_000 // RATE), acc, np.zeros((n, 3), np.int16), np.zeros(n, np.int16))


def _record_and_kill(tmp_path: Path, k: int, delay_s: float, stream: bytes) -> tuple[Path, int]:
    """A recorder on a fresh pty, fed ``RATE`` frames/s in real time from the moment it asks for the header,
    killed ``delay_s`` after that. Returns (output, frames fully written before kill - flush - latency)."""
    from bootnav.logger.protocol import HeaderFrame

    master, slave = os.openpty()
    tty.setraw(slave)
    link = tmp_path / f"tty{k}"
    os.symlink(os.ttyname(slave), link)
    out = tmp_path / f"rec{k}.h5"
    proc = _bootnav("record", "--port", str(link), "--out", str(out), "--flush-interval", str(FLUSH_S),
                    "--header-wait", "0.3", "--quiet")
    written, history = 0, []  # history: (time, frames fully written by then)
    try:
        deadline = time.monotonic() + 60
        while not (select.select([master], [], [], 0.05)[0] and b"H" in os.read(master, 64)):
            assert time.monotonic() < deadline and proc.poll() is None, "the recorder never asked for the header"
        t_ask = time.monotonic()
        os.write(master, HeaderFrame(0, 0, accel_fs=3, gyro_fs=3, dlpf=3, smplrt_div=1).pack())
        os.set_blocking(master, False)
        t_kill = t_ask + delay_s
        while (now := time.monotonic()) < t_kill:
            due = min(len(stream), int((now - t_ask) * RATE) * 26)
            try:
                written += os.write(master, stream[written:due]) if due > written else 0
            except BlockingIOError:
                pass  # the recorder is behind: the pty buffer is full
            history.append((time.monotonic(), written // 26))
            time.sleep(0.01)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        proc.stderr.close()
        os.close(master)
        os.close(slave)
    before = [f for ts, f in history if ts < t_kill - FLUSH_S - LATENCY_S]
    return out, (before[-1] if before else 0)


@pytest.mark.slow
def test_kill9_during_record(tmp_path):
    from bootnav.logger.recording import load

    rng = np.random.default_rng(1403)
    stream = _frames(RATE * 10)
    present, must_hold = [], {}
    for k, delay in enumerate(rng.uniform(0.0, 1.6, N_KILLS)):
        out, n_flushed = _record_and_kill(tmp_path, k, float(delay), stream)
        if n_flushed:  # frames had time to reach a flush: the file must exist and hold them
            assert out.exists(), (k, n_flushed)
        if out.exists():
            present.append(out)
            must_hold[out] = n_flushed
    read = _read_all(present, swmr=True)
    for out in present:
        assert not str(read[str(out)]).startswith("ERROR"), read[str(out)]
        rec = load(out)
        n = rec.n
        assert n >= must_hold[out], (out.name, n, must_hold[out])
        # exactly the frames sent, from the first on: no hole, no zeroed or half-written row
        np.testing.assert_array_equal(rec.seq, np.arange(n))
        np.testing.assert_array_equal(rec.raw["acc"][:, 0], (np.arange(n) % 1000 - 500).astype(np.int16))
        np.testing.assert_array_equal(np.round(np.diff(rec.t_s) * RATE), np.ones(max(n - 1, 0)))
    assert sum(must_hold[o] > 0 for o in present) >= N_KILLS // 3  # many kills came after a flush
