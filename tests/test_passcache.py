"""The spills of the block passes (``postproc.passcache``): a run in many blocks decodes each block, runs the stance
detector and the final filter + smoother once and reads them back, with outputs bit for bit those of the passes
that compute everything again (``SPILL_BUDGET_BYTES = 0``); a budget too small for a spill makes its passes compute
again, with the same outputs."""

import json
import shutil
import tempfile
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from bootnav.postproc import passcache
from bootnav.postproc.pipeline import process_to
from bootnav.postproc.settings import ProcessSettings
from bootnav.simulator.simulate import LongSimulation
from bootnav.simulator.writers import write_long_h5

BLOCK_S = 13.0  # 10 blocks of the 2-min walk


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    """2 min of the long simulation (stairs, clipped rates) and its rows, read whole."""
    d = tmp_path_factory.mktemp("passcache")
    return write_long_h5(LongSimulation(120.0, seed=5, block_s=30.0), d / "walk.h5")


def _settings() -> ProcessSettings:
    s = ProcessSettings()
    s.output.plots = False
    s.block_s = BLOCK_S
    return s


def _run(rec, out, monkeypatch, budget=None):
    """``process_to`` with the spill budget ``budget`` (None: the default); (summary, counts) where counts are the
    smoothed filters made, the stance detectors built and the blocks decoded from the HDF5 file."""
    from bootnav.logger.recording import RecordingReader
    from bootnav.postproc.detectors import stream
    from bootnav.postproc.ins.stream import StreamNavigator

    counts = {"rts": 0, "detectors": 0, "decoded": 0}
    with monkeypatch.context() as m:
        if budget is not None:
            m.setattr(passcache, "SPILL_BUDGET_BYTES", budget)
        real_nav = StreamNavigator.from_initial_state.__func__

        def nav(cls, *a, **k):
            counts["rts"] += a[-1].smoother == "rts"
            return real_nav(cls, *a, **k)

        real_det, real_block = stream.StreamStance.__init__, RecordingReader.block

        def det(self, *a, **k):
            counts["detectors"] += 1
            real_det(self, *a, **k)

        def block(self, i0, i1):
            counts["decoded"] += 1
            return real_block(self, i0, i1)

        m.setattr(StreamNavigator, "from_initial_state", classmethod(nav))
        m.setattr(stream.StreamStance, "__init__", det)
        m.setattr(RecordingReader, "block", block)
        summary, _ = process_to(rec, _settings(), out)
    return summary, counts


def _assert_same(d1, d2):
    """Bit for bit: trajectory.csv, steps.csv, every array of results.h5, summary.json but its timings."""
    for name in ("trajectory.csv", "steps.csv"):
        assert (d1 / name).read_bytes() == (d2 / name).read_bytes(), name
    with h5py.File(d1 / "results.h5", "r") as f1, h5py.File(d2 / "results.h5", "r") as f2:
        names = []
        f1["results"].visititems(lambda nm, o: names.append(nm) if isinstance(o, h5py.Dataset) else None)
        assert len(names) > 10
        for nm in names:
            np.testing.assert_array_equal(f1["results"][nm][()], f2["results"][nm][()], err_msg=nm)

    def plain(d):
        s = json.loads((d / "summary.json").read_text())
        s.pop("timings_s")
        for k in ("run_s", "compile_s"):  # the filter's own clocks
            s["filter"].pop(k)
        s.pop("files")
        return s

    assert plain(d1) == plain(d2)


def test_spilled_passes_give_the_outputs_of_the_passes_computed_again(walk, tmp_path, monkeypatch):
    on, c_on = _run(walk, tmp_path / "on", monkeypatch)
    off, c_off = _run(walk, tmp_path / "off", monkeypatch, budget=0)
    assert on["navigation"]["blocks"] == off["navigation"]["blocks"] >= 10
    _assert_same(tmp_path / "on", tmp_path / "off")
    # replayed: the final pass runs no filter of its own, the configured detector runs once (and once more for
    # the noise floor), every block is decoded once (the checks' windows and the unit check's rows apart)
    assert c_on["rts"] == c_off["rts"] - 1
    assert c_on["detectors"] == 2 < c_off["detectors"]
    blocks = on["navigation"]["blocks"]
    assert c_on["decoded"] == 2 * blocks + 1 < c_off["decoded"]


@pytest.mark.parametrize("bytes_per_sample", [60, 140, 250])
def test_a_spill_over_the_budget_is_computed_again(walk, tmp_path, monkeypatch, bytes_per_sample):
    """A budget that holds the decoded samples (57 B per sample) but not the stance chunks (+74 B), or those but not
    the filter's rows (+170 B), or the filter's rows only in part: the spills over it are dropped and their passes
    compute again, with the same outputs."""
    off, _ = _run(walk, tmp_path / "off", monkeypatch, budget=0)
    n = off["input"]["samples_processed"]
    small, c = _run(walk, tmp_path / "small", monkeypatch, budget=bytes_per_sample * n)
    _assert_same(tmp_path / "small", tmp_path / "off")
    _, c_on = _run(walk, tmp_path / "on", monkeypatch)
    assert c["rts"] == c_on["rts"] + 1  # the filter's rows did not fit: the final pass ran its own filter
    assert c["detectors"] > c_on["detectors"] or bytes_per_sample > 130


def test_array_file_refuses_over_its_budget_and_keeps_what_it_held(tmp_path):
    budget = passcache.SpillBudget(1000, tmp_path)
    f = budget.open("t-")
    a = np.arange(50, dtype=np.float64)  # 400 B
    places = f.write([a, None, a.astype(bool)])
    assert budget.used == 450
    got = f.read(places)
    np.testing.assert_array_equal(got[0], a)
    assert got[1] is None and got[2].dtype == bool and got[2].sum() == 49
    assert f.write([a]) is not None and budget.used == 850
    assert f.write([a]) is None  # 1250 B > 1000 B
    assert f.full and f.write([a[:1]]) is None  # and every write after it
    np.testing.assert_array_equal(f.read(places)[0], a)  # a pass replaying it reads on
    f.close()
    assert budget.used == 0


class _SmallDisk:
    """A temporary file on a disk with ``free`` bytes left (then ENOSPC), shared by every file opened."""

    free = 0
    refused = 0

    def __init__(self, *a, **k):
        self._f = tempfile.TemporaryFile()

    def write(self, b):
        import errno

        n = memoryview(b).nbytes
        if n > _SmallDisk.free:
            _SmallDisk.refused += 1
            raise OSError(errno.ENOSPC, "No space left on device")
        _SmallDisk.free -= n
        return self._f.write(b)

    def __getattr__(self, name):
        return getattr(self._f, name)


@pytest.mark.parametrize("bytes_per_sample", [30, 140])
def test_a_full_disk_is_computed_again(walk, tmp_path, monkeypatch, bytes_per_sample):
    """The disk fills up in the middle of the decoded samples, or of the filter's rows: the same outputs."""
    off, _ = _run(walk, tmp_path / "off", monkeypatch, budget=0)
    monkeypatch.setattr(_SmallDisk, "free", bytes_per_sample * off["input"]["samples_processed"])
    monkeypatch.setattr(_SmallDisk, "refused", 0)
    small = SimpleNamespace(TemporaryFile=_SmallDisk, gettempdir=tempfile.gettempdir)
    monkeypatch.setattr(passcache, "tempfile", small)
    _, c = _run(walk, tmp_path / "full", monkeypatch)
    _assert_same(tmp_path / "full", tmp_path / "off")
    assert _SmallDisk.refused >= 1  # it did fill up
    blocks = off["navigation"]["blocks"]
    if bytes_per_sample < 57:  # some blocks decoded again
        assert c["decoded"] > 2 * blocks + 1
    else:  # the filter's rows not kept: the final pass runs its own filter (as with no spill)
        assert c["rts"] == 2 + off["filter"]["heading_decision"]["on"]


def test_rows_over_the_budget_are_not_replayed(tmp_path):
    from bootnav.postproc.ins.stream import NavRows

    def rows(start, m):
        z3 = np.full((m, 3), float(start))
        return NavRows(start, np.arange(start, start + m, dtype=float), z3, z3, np.ones((m, 4)), z3, z3, z3,
                       np.zeros(m), np.ones(m, bool), np.zeros(m, bool))

    spill = passcache.PassSpills([(0, 10), (10, 20)], passcache.SpillBudget(2000, tmp_path))
    kept = spill.nav_rows()
    kept.append(rows(0, 3))
    kept.append(rows(3, 0))
    assert kept.kept
    back = list(kept)
    assert [r.start for r in back] == [0, 3] and len(back[0]) == 3 and len(back[1]) == 0
    np.testing.assert_array_equal(back[0].q_nb, np.ones((3, 4)))
    assert back[0].stance.dtype == bool
    lost = spill.nav_rows()
    for i in range(10):
        lost.append(rows(3 * i, 3))  # 3 × 170 B each
    assert not lost.kept


def test_the_budget_is_at_most_half_the_free_space(tmp_path, monkeypatch):
    monkeypatch.setattr(shutil, "disk_usage", lambda p: SimpleNamespace(total=20_000, used=10_000, free=10_000))
    assert passcache.SpillBudget(None, tmp_path).limit == 5_000
    assert passcache.SpillBudget(3_000, tmp_path).limit == 3_000


def test_no_spill_on_a_file_system_in_memory(tmp_path, monkeypatch):
    """A temporary folder on tmpfs holds its files in memory: the spills would be memory growing with the length."""
    mounts = tmp_path / "mounts"
    mounts.write_text(f"/dev/vda / ext4 rw 0 0\ntmpfs {tmp_path} tmpfs rw 0 0\n")
    real_open = open

    def fake_open(f, *a, **k):
        return real_open(mounts if f == "/proc/self/mounts" else f, *a, **k)

    monkeypatch.setattr("builtins.open", fake_open)
    assert passcache.ram_backed(tmp_path) and passcache.ram_backed(tmp_path / "x")
    assert not passcache.ram_backed(tmp_path.parent)
    assert passcache.SpillBudget(None, tmp_path).limit == 0
    assert passcache.SpillBudget(None, tmp_path.parent).limit > 0
