"""``process`` on two cores (issue 18): the charts are drawn by two forked processes (``outputs.ChartWorker``)
while the CSV and HDF5 files are written. Their charts are the ones this process would draw, byte for byte; a
failure (an exception, a crash) is a warning and never costs another output; Ctrl-C (``close``) or the death
of the parent ends them without a zombie and without a half-written chart; the CSV kernel's first compilation
is announced.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from bootnav.core import atomic
from bootnav.postproc import plots
from bootnav.postproc.outputs import ChartWorker, draw_here, write_outputs
from bootnav.postproc.pipeline import process
from bootnav.postproc.settings import ProcessSettings
from tests.conftest import REPO

BUNDLED = REPO / "recordings" / "xio_ngimu_short_walk.h5"
NOT_CHARTS = {"trajectory.csv", "steps.csv", "summary.json", "results.h5"}


@pytest.fixture(scope="module")
def result():
    if not BUNDLED.exists():
        pytest.skip("recordings/ not present")
    return process(BUNDLED, ProcessSettings(crop_s=(0.0, 20.0)))


@pytest.fixture(scope="module")
def complete(result, tmp_path_factory):
    """The outputs of an undisturbed run."""
    out = tmp_path_factory.mktemp("complete")
    return out, write_outputs(result, out)


def _gone(pid: int) -> bool:
    """The process has ended (reaped, or a zombie of a parent that is not this test)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] == "Z"
    except FileNotFoundError:
        return True


def test_the_charts_of_the_child_are_those_drawn_here(result, complete, tmp_path):
    out, files = complete
    assert {k for k in files if k.startswith("plot_")} == {f"plot_{k}" for k in plots.FILES} and "html" in files
    drawn, error = draw_here(plots.ChartStream.from_result(result), tmp_path)
    assert error is None
    for name in [*plots.FILES.values(), "path.html"]:
        assert (out / name).read_bytes() == (tmp_path / name).read_bytes(), name


@pytest.mark.parametrize("failure", ["exception", "crash"])
def test_a_chart_failure_is_a_warning_and_the_other_outputs_are_complete(result, complete, tmp_path, monkeypatch,
                                                                          failure):
    def fail(stream, out_dir, keys=None):  # runs in the forked chart processes
        if failure == "crash":
            os.kill(os.getpid(), signal.SIGKILL)
        raise RuntimeError("no fonts here")

    monkeypatch.setattr(plots, "draw_charts", fail)
    out = tmp_path / "out"
    files = write_outputs(result, out)
    assert not any(k.startswith("plot_") or k == "html" for k in files)
    assert {p.name for p in out.iterdir()} == NOT_CHARTS  # no chart, no temporary file
    warnings = json.loads((out / "summary.json").read_text())["warnings"]
    why = "RuntimeError: no fonts here" if failure == "exception" else "exit code -9"
    assert any("the charts were not drawn" in w and why in w for w in warnings), warnings
    ref = complete[0]
    for name in ("trajectory.csv", "steps.csv"):
        assert (out / name).read_bytes() == (ref / name).read_bytes()
    with h5py.File(out / "results.h5", "r") as f, h5py.File(ref / "results.h5", "r") as g:
        for key, ds in g["results/default"].items():
            if isinstance(ds, h5py.Dataset):
                assert np.array_equal(f["results/default"][key][()], ds[()]), key


def _slow_chart(stream, out_dir, keys=None):
    """A chart that is being written when the child is stopped: its temporary file exists, then a mark."""
    def write(tmp):
        tmp.write_bytes(b"half a chart")
        (out_dir / "started").touch()
        time.sleep(60)

    atomic.replace_with(out_dir / "1_raw_imu.png", write)


def _wait_for(path, timeout_s=30.0):
    t0 = time.monotonic()
    while not path.exists():
        assert time.monotonic() - t0 < timeout_s, f"{path} never appeared"
        time.sleep(0.02)


class _Unpicklable:
    def __reduce__(self):
        raise MemoryError("no memory left to pickle the charts")


def test_a_job_that_cannot_be_sent_is_reported_not_waited_for(tmp_path):
    worker = ChartWorker.start()
    pid = worker._proc.pid
    worker.submit(_Unpicklable(), tmp_path)
    t0 = time.monotonic()
    drawn, error = worker.wait()  # would block forever on the child's answer if it waited
    assert time.monotonic() - t0 < 10.0
    assert drawn == {} and error == "MemoryError: no memory left to pickle the charts"
    assert _gone(pid)


def test_close_ends_a_drawing_child_without_a_half_written_chart(result, tmp_path, monkeypatch):
    monkeypatch.setattr(plots, "draw_charts", _slow_chart)
    worker = ChartWorker.start()
    worker.submit(plots.ChartStream.from_result(result), tmp_path)
    _wait_for(tmp_path / "started")
    pid = worker._proc.pid
    worker.close()  # what Ctrl-C does (cli_process._one's finally)
    assert worker._proc.exitcode == 128 + signal.SIGTERM  # ended through its handler: it cleaned up
    assert _gone(pid)
    assert [p.name for p in tmp_path.iterdir()] == ["started"]


def test_the_child_ends_with_its_parent(tmp_path):
    script = (
        "import sys, time\n"
        "from pathlib import Path\n"
        "from bootnav.postproc import plots\n"
        "from bootnav.postproc.outputs import ChartWorker\n"
        "from tests.test_process_overlap import _slow_chart\n"
        "plots.draw_charts = _slow_chart\n"
        "w = ChartWorker.start()\n"
        "w.submit(None, Path(sys.argv[1]))\n"
        "print(w._proc.pid, flush=True)\n"
        "time.sleep(60)\n"
    )
    parent = subprocess.Popen([sys.executable, "-c", script, str(tmp_path)], cwd=REPO, stdout=subprocess.PIPE,
                              text=True)
    try:
        child = int(parent.stdout.readline())
        _wait_for(tmp_path / "started")
    finally:
        parent.kill()  # SIGKILL: no clean-up of its own
        parent.wait()
        parent.stdout.close()
    t0 = time.monotonic()
    while not _gone(child):
        assert time.monotonic() - t0 < 5.0, "the chart process outlived its parent"
        time.sleep(0.02)
    assert [p.name for p in tmp_path.iterdir()] == ["started"]


def test_the_csv_writer_says_when_it_compiles(tmp_path):
    """A first run on a machine (an empty numba cache) is told before the CSV kernel compiles; not later."""
    script = ("from bootnav.postproc.outputs import warm_csv_writer\n"
              "warm_csv_writer(lambda: print('compiling'))\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    told = [subprocess.run([sys.executable, "-c", script], cwd=REPO, env=env, capture_output=True, text=True,
                           timeout=120, check=True).stdout for _ in range(2)]
    assert told == ["compiling\n", ""]
