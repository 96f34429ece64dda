"""Issue 27 at the process level: stop signals, the file-size limit (SIGXFSZ), odd consoles, a closed stdout,
a recorder on a nearly full disk, and the stride-level warning of a split gait."""

from __future__ import annotations

import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import REPO

REC = REPO / "recordings" / "sim_paper-straight.h5"
pytestmark = pytest.mark.timeout(120)


def _bootnav(args, *, preexec=None, env=None, stdout=subprocess.PIPE, encoding="utf-8") -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "bootnav", *map(str, args)], cwd=REPO, stdout=stdout,
                            stderr=subprocess.PIPE, text=True, preexec_fn=preexec, encoding=encoding,
                            env={**os.environ, **(env or {})})


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_a_stop_signal_is_like_ctrl_c(tmp_path, sig):
    """Exit 128 + signal (as Ctrl-C gives 130), one line, no output and no hidden temporary file left."""
    rec = tmp_path / "rec.h5"
    shutil.copy(REC, rec)
    out = tmp_path / "o"
    proc = _bootnav(["process", rec, "--out", out])
    time.sleep(4.0)  # inside the run (imports, compile check, load, navigation)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.skip("the run finished before the signal (a very fast machine)")
    assert proc.returncode == 128 + sig, err
    lines = [ln for ln in err.splitlines() if ln.startswith("bootnav process: stopped")]
    assert lines == [f"bootnav process: stopped by {signal.Signals(sig).name}; unfinished output files were removed"]
    assert "Traceback" not in err
    assert not out.exists() or list(out.iterdir()) == []


def test_import_stopped_by_sigterm_leaves_no_temporary_file(tmp_path):
    csv = tmp_path / "big.csv"
    rows = "\n".join(f"{i / 100:.2f},0.1,0.2,9.8,0.01,0.02,0.03" for i in range(400_000))
    csv.write_text("t_s,ax,ay,az,gx,gy,gz\n" + rows + "\n")
    proc = _bootnav(["import", csv, "--acc-unit", "mps2", "--gyro-unit", "radps", "--out", tmp_path / "x.h5"])
    time.sleep(2.0)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.skip("the import finished before the signal")
    assert proc.returncode == 143 and "stopped by SIGTERM" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.csv"]


def test_process_under_a_file_size_limit_fails_cleanly(tmp_path):
    """RLIMIT_FSIZE with the default SIGXFSZ action: the process must not be killed or segfault, say EFBIG in one
    line naming the output (not the hidden temporary), and leave no partial output set."""
    rec = tmp_path / "rec.h5"
    shutil.copy(REC, rec)
    limit = 150_000  # smaller than the outputs of this 28 s walk (trajectory.csv, results.h5)

    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.RLIM_INFINITY))  # SIGXFSZ left at its default

    proc = _bootnav(["process", rec, "--out", tmp_path / "o", "--no-plots", "-q"], preexec=apply)
    _, err = proc.communicate(timeout=100)
    assert proc.returncode == 1, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bootnav process: error: "), err
    assert lines[0].endswith("File too large; the file-size limit was reached (ulimit -f)") and ".tmp" not in err
    assert not (tmp_path / "o").exists() or list((tmp_path / "o").iterdir()) == []


@pytest.mark.parametrize("env", [{"PYTHONIOENCODING": "ascii"}, {"PYTHONIOENCODING": "cp1252"}])
def test_a_console_that_cannot_show_our_symbols_gets_ascii(env):
    proc = _bootnav(["info", REC], env=env, encoding=env["PYTHONIOENCODING"])
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    # ASCII: ± and ° spelled out ("+-", "deg"); cp1252 has both characters
    assert ("+-" in out and "deg" in out) if env["PYTHONIOENCODING"] == "ascii" else "±" in out


def test_a_closed_stdout_is_not_an_error(tmp_path):
    def close_stdout():
        os.close(1)

    proc = _bootnav(["info", REC], preexec=close_stdout, stdout=None)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0 and "Error" not in err, err


def test_the_missing_folder_is_named_not_the_hidden_temporary(tmp_path):
    from bootnav.cli import _os_message

    hidden = tmp_path / "nodir" / f".results.h5.{os.getpid()}.tmp"
    msg = _os_message(FileNotFoundError(2, "No such file or directory", str(hidden)))
    assert ".tmp" not in msg and f"the folder {tmp_path / 'nodir'} does not exist" in msg


def test_recorder_keeps_what_fits_on_a_nearly_full_disk(tmp_path):
    """300 KB of room (the file-size limit): the first chunks must fit, so tens of seconds are kept, not 0 frames.

    The writer is driven as the serial recorder drives it (``room_for`` before each flush of 0.5 s)."""
    code = (
        "import resource, signal, sys, numpy as np\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (300_000, resource.RLIM_INFINITY))\n"
        "from bootnav.logger.recording import RecordingWriter, counts_channel, load\n"
        "from bootnav.errors import DiskFullError\n"
        "rng = np.random.default_rng(0)\n"
        "w = RecordingWriter(sys.argv[1], counts_channel('acc', 16 * 9.80665 / 32768), counts_channel('gyro', 1e-3),"
        " temp=counts_channel('temp', 1 / 340), device_time=True, host_time=True, seq=True)\n"
        "n, k = 0, 100\n"
        "while w.room_for(k):\n"
        "    t = (n + np.arange(k)) / 200.0\n"
        "    acc = rng.integers(-3000, 3000, (k, 3), dtype=np.int16); acc[:, 2] += 2048\n"
        "    w.append(t, acc, rng.integers(-500, 500, (k, 3), dtype=np.int16), temp=np.zeros(k, np.int16),"
        " t_device=(t * 1e6).astype(np.uint32), t_host=t, seq=((n + np.arange(k)) % 65536).astype(np.uint16))\n"
        "    w.flush(); n += k\n"
        "w.close()\n"
        "print(load(sys.argv[1]).n)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code, str(tmp_path / "r.h5")], capture_output=True, text=True,
                          cwd=REPO, timeout=100)
    assert proc.returncode == 0, proc.stderr
    kept_s = int(proc.stdout.strip()) / 200.0
    # 300 KB hold >= 20 s of the worst case (incompressible int16 noise): 37 B/row uncompressed = 7.4 KB/s
    assert kept_s >= 20.0, kept_s


def test_record_says_at_start_how_many_minutes_fit(tmp_path, capsys):
    from bootnav.logger.cli_record import check_free_space

    code = ("import resource, sys\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (600_000, resource.RLIM_INFINITY))\n"
            "from bootnav.logger.cli_record import check_free_space\n"
            "print(check_free_space(sys.argv[1]))\n")
    proc = subprocess.run([sys.executable, "-c", code, str(tmp_path / "r.h5")], capture_output=True, text=True,
                          cwd=REPO, timeout=60)
    minutes = float(proc.stdout)
    # (600 000 - 65 536) B / (37 B x 200 Hz) / 60 = 1.2 min
    assert abs(minutes - (600_000 - 65_536) / (37 * 200) / 60) < 0.01
    assert "about 1.2 min of recording" in proc.stderr
    assert check_free_space(tmp_path / "r.h5", quiet=True) > 0


def test_split_strides_warn(tmp_path):
    """Footprints closer in time than half the gait period: a stance inside a swing (simulated shuffle walk)."""
    from bootnav.postproc.selftune import SelfTuneSettings, StrideQuality, split_strides

    def quality(durations):
        d = np.asarray(durations, float)
        return StrideQuality(np.zeros(len(d), np.uint8), d, d * 0.6, np.zeros(len(d)), 0.0)

    period = 1.2
    assert split_strides(quality([1.2] * 20), period) is None  # a walk
    assert split_strides(quality([1.2] * 12 + [0.4] * 8), period) is None  # turns on the spot: a minority
    w = split_strides(quality([0.4] * 16 + [1.2] * 4), period)
    assert w is not None and "80% of the 20 strides" in w
    # the boundary is the stated rule (half the period, more than half of the strides)
    s = SelfTuneSettings()
    assert split_strides(quality([0.59] * 10 + [0.61] * 10), period, s) is None
    assert split_strides(quality([0.59] * 11 + [0.61] * 9), period, s) is not None


@pytest.mark.timeout(120)
def test_the_shuffle_walk_warns_about_its_strides(tmp_path):
    import bootnav
    from bootnav.simulator import simulate, write_h5

    path = tmp_path / "shuffle.h5"
    write_h5(simulate("shuffle", seed=0), path)
    res = bootnav.process(str(path), output={"plots": False})
    from bootnav.logger.recording import load

    truth = float(np.sum(load(path).truth["step_length_m"]))
    if res.summary["distance_m"] > 0.8 * truth:
        pytest.skip("the stance detector no longer splits this walk")
    assert any("less than half the gait cycle" in w for w in res.warnings), res.warnings


def test_a_stop_while_the_charts_are_drawn_leaves_no_chart(tmp_path, monkeypatch):
    """A stop that lands while the chart processes draw (the end of a short run): the chart processes must end
    before the outputs are removed, or one renames its chart into place after the removal (found by the
    SIGHUP test above once a short run took less than its 4 s)."""
    from bootnav.postproc import outputs
    from bootnav.postproc.pipeline import process_to
    from bootnav.postproc.settings import ProcessSettings

    out = tmp_path / "o"

    def stopped_at_the_first_chart(self):
        deadline = time.monotonic() + 60.0
        while not list(out.glob("*.png")) and time.monotonic() < deadline:  # one chart is on disk: the others
            time.sleep(0.005)  # are being drawn
        raise KeyboardInterrupt

    close = outputs.ChartWorker.close

    def slow_close(self):  # the chart processes draw on for a while before they are ended, as under load
        time.sleep(1.5)  # longer than drawing the remaining charts takes
        close(self)

    monkeypatch.setattr(outputs.ChartWorker, "wait", stopped_at_the_first_chart)
    monkeypatch.setattr(outputs.ChartWorker, "close", slow_close)
    with pytest.raises(KeyboardInterrupt):
        process_to(REC, ProcessSettings(), out)
    assert not out.exists() or sorted(p.name for p in out.iterdir()) == []
