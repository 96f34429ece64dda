"""The incremental engine (``bootnav.postproc.ins.stream.StreamNavigator``): any chunking gives the whole-array
``run_filter`` result; rows are final when returned and memory is bounded; external measurements; the numba
cache is keyed on every module the kernel inlines."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import bootnav
from bootnav.core.timebase import time_base
from bootnav.errors import InputError
from bootnav.postproc.calibration import initial_alignment
from bootnav.postproc.detectors import DetectorSettings, detect_stance
from bootnav.postproc.ins import FilterSettings, run_filter
from bootnav.postproc.ins.stream import NavRows, StreamNavigator
from bootnav.postproc.settings import ProcessSettings
from tests.conftest import REPO

G = 9.80665
CONFIGS = {
    "9-rts": dict(n_states=9),
    "15-rts": dict(n_states=15),
    "15-none": dict(n_states=15, smoother="none"),
    "riccati": dict(mode="riccati"),
}


def _walk(t, acc, gyr, saturated):
    stance = detect_stance(t, acc, gyr, DetectorSettings(), G, saturated=saturated).stance
    return t, acc, gyr, stance, initial_alignment(t, acc, gyr, gravity=G), saturated


@pytest.fixture(scope="module")
def walks():
    """A simulated stair walk (bootnav.simulator, MPU6050 model, 200 Hz) and the bundled real x-io loop
    (NGIMU, 400 Hz, its clock shifted to start at 1000 s), each with a burst of clipped samples marked
    saturated (the per-sample noise path)."""
    from bootnav.simulator.simulate import simulate

    sim = simulate("paper-stairs", seed=3)
    rec = bootnav.load(REPO / "recordings" / "xio_ngimu_short_walk.h5")
    out = {}
    for name, (t, acc, gyr) in {"sim-stairs": (sim.t_s, sim.acc_mps2, sim.gyro_radps),
                                "xio-real": (rec.t_s - rec.t_s[0] + 1000.0, rec.acc_mps2, rec.gyro_radps)}.items():
        sat = np.zeros(t.shape[0], np.uint8)
        sat[t.shape[0] // 3:t.shape[0] // 3 + 30] = 0b100001  # ax and gx clipped
        out[name] = _walk(np.asarray(t, float), np.asarray(acc, float), np.asarray(gyr, float), sat)
    return out


def _stream(walk, fs, sizes, nominal_dt=None):
    """Push ``walk`` in chunks of ``sizes`` (an int or a generator of ints); return (rows, navigator, most
    rows held back at once)."""
    t, acc, gyr, stance, init, sat = walk
    nav = StreamNavigator.from_initial_state(init, G, nominal_dt or time_base(t).nominal_dt_s, fs)
    parts, i, held = [], 0, 0
    while i < t.shape[0]:
        c = sizes if isinstance(sizes, int) else next(sizes)
        parts.append(nav.push(t[i:i + c], acc[i:i + c], gyr[i:i + c], stance[i:i + c], saturated=sat[i:i + c]))
        held = max(held, nav.n_pushed - parts[-1].start - len(parts[-1]))
        i += c
    parts.append(nav.finish())
    return NavRows.concatenate(parts), nav, held


def _random_sizes(seed):
    rng = np.random.default_rng(seed)
    while True:
        yield int(rng.integers(1, 400))


def _assert_same(rows, sol, n_states):
    assert rows.start == 0 and len(rows) == sol.t_s.shape[0]
    assert np.array_equal(rows.t_s, sol.t_s)
    assert np.abs(rows.pos_n - sol.pos_n).max() <= 1e-9  # the requirement: 1e-9 m
    for name in ("vel_n", "q_nb", "pos_sigma_n"):
        assert np.abs(getattr(rows, name) - getattr(sol, name)).max() <= 1e-12, name
    if n_states == 15:
        assert np.abs(rows.acc_bias_b - sol.acc_bias_b).max() <= 1e-12
        assert np.abs(rows.gyro_bias_b - sol.gyro_bias_b).max() <= 1e-12


@pytest.mark.parametrize("data", ["sim-stairs", "xio-real"])
@pytest.mark.parametrize("config", list(CONFIGS))
def test_any_chunking_equals_whole_record(walks, data, config):
    """5 chunkings (1 sample, 7, 1000, random 1-399, the whole record at once) give run_filter's path."""
    walk = walks[data]
    t, acc, gyr, stance, init, sat = walk
    fs = FilterSettings(**CONFIGS[config])
    sol = run_filter(t, acc, gyr, stance, init, G, fs, saturated=sat)
    assert sol.info["n_updates"] > 1000 and sol.info["saturated_samples_inflated"] == 30
    chunkings = [7, 1000, _random_sizes(1), t.shape[0]]
    if data == "sim-stairs":  # 1-sample pushes cost ~0.15 ms each: the shorter record
        chunkings.insert(0, 1)
    for sizes in chunkings:
        rows, nav, _ = _stream(walk, fs, sizes)
        _assert_same(rows, sol, fs.n_states)
        assert nav.info["n_updates"] == sol.info["n_updates"]
        assert nav.info["smoother_segments"] == sol.info["smoother_segments"]
        assert np.array_equal(rows.stance, stance)


def test_memory_is_bounded_by_segment_and_lookahead(walks):
    """Rows held back never exceed the smoother's segment cap + the onset-delay look-ahead + one chunk, and
    with a short segment cap the segments are split (still the same path)."""
    t, acc, gyr, stance, init, sat = walks["xio-real"]
    dt = time_base(t).nominal_dt_s
    fs = FilterSettings(smoother_max_segment_s=0.3)
    rows, nav, held = _stream(walks["xio-real"], fs, 7)
    _assert_same(rows, run_filter(t, acc, gyr, stance, init, G, fs, saturated=sat), 15)
    lookahead = math.ceil(fs.zupt_onset_delay_s / fs.zupt_onset_max_fraction / dt) + 2
    assert held <= nav.prm.max_segment + lookahead + 7
    assert nav._buf_post.shape[0] == nav.prm.max_segment == math.ceil(0.3 / dt)
    # the default cap: rows of a whole stride are held, never the record
    rows, nav, held = _stream(walks["xio-real"], FilterSettings(), 1000)
    assert held <= nav.prm.max_segment + lookahead + 1000 < t.shape[0] / 2


def test_rows_are_final_when_returned(walks):
    """Copies of the rows taken at each push equal the rows at the end (nothing returned changes later)."""
    t, acc, gyr, stance, init, sat = walks["sim-stairs"]
    nav = StreamNavigator.from_initial_state(init, G, time_base(t).nominal_dt_s, FilterSettings())
    copies, parts = [], []
    for i in range(0, t.shape[0], 50):
        r = nav.push(t[i:i + 50], acc[i:i + 50], gyr[i:i + 50], stance[i:i + 50], saturated=sat[i:i + 50])
        parts.append(r)
        copies.append(r.pos_n.copy())
        assert r.start == (parts[-2].start + len(parts[-2]) if len(parts) > 1 else 0)
    parts.append(nav.finish())
    assert all(np.array_equal(c, p.pos_n) for c, p in zip(copies, parts))
    assert sum(len(p) > 0 for p in parts) > 10  # strides came out as they were walked, not at the end


def test_from_still_aligns_like_process(walks):
    """Built from ProcessSettings, the rate and the first 20 s (the rest lasts 14 s), the navigator has
    process's initial state and gives run_filter's path (same rate and gravity)."""
    t, acc, gyr, stance, init, sat = walks["xio-real"]
    rate = 1.0 / time_base(t).nominal_dt_s
    settings = ProcessSettings()
    k = int(np.searchsorted(t, t[0] + 20.0))
    nav = StreamNavigator.from_still(settings, rate, t[:k], acc[:k], gyr[:k])
    g = settings.calibration.gravity()
    full = initial_alignment(t, acc, gyr, settings.calibration, g)
    assert np.abs(nav.init_state.q_nb - full.q_nb).max() < 1e-12
    assert np.abs(nav.init_state.gyro_bias_b - full.gyro_bias_b).max() < 1e-12
    rows = NavRows.concatenate([nav.push(t, acc, gyr, stance, saturated=sat), nav.finish()])
    _assert_same(rows, run_filter(t, acc, gyr, stance, full, g, settings.filter, saturated=sat), 15)


@pytest.mark.parametrize("n_states", [9, 15])
def test_position_measurement_moves_the_last_sample(n_states):
    """A still record: a position fix with tiny R at the last pushed sample moves the position there (the
    Kalman result for the prior P), shrinks its covariance to ~R, and the smoother carries it back over the
    open segment (monotonically: the older the sample, the smaller its share) but not into closed ones."""
    n = 600
    t = np.arange(n) * 0.01
    acc = np.tile([0.0, 0.0, G], (n, 1))
    gyr = np.zeros((n, 3))
    stance = np.ones(n, bool)
    stance[200:260] = False  # one "swing" (no motion): the first segment closes at its start, sample 200

    class Init:
        q_nb = np.array([1.0, 0.0, 0.0, 0.0])
        gyro_bias_b = np.zeros(3)

    nav = StreamNavigator.from_initial_state(Init(), G, 0.01, FilterSettings(n_states=n_states))
    parts = [nav.push(t, acc, gyr, stance)]
    assert nav.last_index == n - 1 and np.allclose(nav.position_n, 0.0)
    p_prior = nav.position_cov_n
    fix = np.array([0.3, -0.2, 0.1])
    r = 1e-8
    H = np.zeros((3, n_states))
    H[:, :3] = np.eye(3)
    nav.apply_measurement(fix - nav.position_n, H, np.eye(3) * r)
    expected = p_prior @ np.linalg.solve(p_prior + np.eye(3) * r, fix)
    assert np.abs(nav.position_n - expected).max() < 1e-12
    assert np.abs(nav.position_n - fix).max() < 0.01 * np.abs(fix).max()  # P ≫ R: it goes (almost) there
    assert np.abs(nav.position_cov_n - np.linalg.inv(np.linalg.inv(p_prior) + np.eye(3) / r)).max() < 1e-15
    parts.append(nav.finish())
    rows = NavRows.concatenate(parts)
    assert np.abs(rows.pos_n[-1] - nav.position_n).max() == 0.0
    assert nav.info["external_updates"] == 1
    x = rows.pos_n[:, 0]
    assert np.all(x[:200] == 0.0)  # the closed segment is untouched
    seg = x[200:]  # the open one (swing + stance, < smoother_max_segment_s) carries the fix back
    assert seg[0] > 0 and np.all(np.diff(seg) >= -1e-12) and seg[-1] == pytest.approx(expected[0], abs=1e-12)
    with pytest.raises(InputError, match="finished"):
        nav.apply_measurement(np.zeros(3), H, np.eye(3))


def test_bad_pushes_are_refused_with_the_sample_index():
    class Init:
        q_nb = np.array([1.0, 0.0, 0.0, 0.0])
        gyro_bias_b = np.zeros(3)

    nav = StreamNavigator.from_initial_state(Init(), G, 0.01)
    t = np.arange(10) * 0.01
    acc, gyr, st = np.tile([0.0, 0.0, G], (10, 1)), np.zeros((10, 3)), np.ones(10, bool)
    nav.push(t, acc, gyr, st)
    with pytest.raises(InputError, match="backwards at sample 10"):
        nav.push(t[:3], acc[:3], gyr[:3], st[:3])
    bad = acc.copy()
    bad[4, 1] = np.nan
    with pytest.raises(InputError, match="non-finite value .* at sample 14"):
        nav.push(t + 1, bad, gyr, st)
    with pytest.raises(InputError, match="expected"):
        nav.push(t + 1, acc[:5], gyr, st)
    with pytest.raises(InputError, match="apply_measurement: expected"):
        nav.apply_measurement(np.zeros(3), np.zeros((3, 9)), np.eye(2))
    with pytest.raises(InputError, match="gravity"):
        StreamNavigator.from_initial_state(Init(), 0.0, 0.01)


def test_numba_cache_is_keyed_on_the_inlined_modules(tmp_path):
    """Editing a module whose jitted function a cached kernel calls recompiles the kernel; numba's own key
    (the caller's file only) would load the stale one. Fresh processes, a private numba cache."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "dep.py").write_text("from numba import njit\n\n@njit(cache=True)\ndef f():\n    return 1.0\n")
    (pkg / "main.py").write_text(textwrap.dedent(f"""
        import sys
        from pathlib import Path
        from numba import njit
        from dep import f
        from bootnav.postproc.ins.fast import key_cache_on_sources

        @njit(cache=True)
        def g():
            return f() + 10.0

        if sys.argv[1] == "keyed":
            key_cache_on_sources([g], sorted(Path({str(pkg)!r}).glob("*.py")))
        print(g())
        """))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=f"{pkg}{os.pathsep}{REPO}")

    def run(mode):
        return subprocess.run([sys.executable, str(pkg / "main.py"), mode], env=env, capture_output=True,
                              text=True, check=True, timeout=120).stdout.strip()

    for mode in ("plain", "keyed"):
        (pkg / "dep.py").write_text((pkg / "dep.py").read_text().replace("return 2.0", "return 1.0"))
        assert run(mode) == "11.0"
        (pkg / "dep.py").write_text((pkg / "dep.py").read_text().replace("return 1.0", "return 2.0"))
        result = run(mode)
        assert result == ("11.0" if mode == "plain" else "12.0")  # plain: numba's stale cache (the wart)


def test_compile_notice_only_when_not_cached(tmp_path):
    """The notice listeners are told only when the kernels are not in numba's cache."""
    from bootnav.postproc.ins import fast

    told = []
    with fast.compile_notice(lambda: told.append(1)):
        StreamNavigator.from_initial_state(type("I", (), {"q_nb": [1.0, 0, 0, 0], "gyro_bias_b": np.zeros(3)})(),
                                           G, 0.01)
    assert told == []  # compiled or loaded in this process by now: no notice
    code = ("from bootnav.postproc.ins import fast; "
            "print(fast._cached_on_disk(fast.filter_chunk), fast._cached_on_disk(fast.close_segment))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120,
                         env=dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "empty")), cwd=REPO).stdout
    assert out.split() == ["False", "False"]


def test_process_says_when_it_compiles(tmp_path, monkeypatch, capsys):
    """`bootnav process` shows "compiling numerical kernels (first run only)" when the kernels must be
    compiled (forced here: the machine's cache is warm), and not otherwise."""
    from bootnav.cli import main
    from bootnav.postproc.ins import fast

    rec = REPO / "recordings" / "sim_paper-stairs.h5"
    assert main(["process", str(rec), "--out", str(tmp_path / "a"), "--no-plots"]) == 0
    assert "compiling" not in capsys.readouterr().err
    monkeypatch.setattr(fast, "_needs_compiling", lambda: True)
    assert main(["process", str(rec), "--out", str(tmp_path / "b"), "--no-plots"]) == 0
    assert "bootnav process: compiling numerical kernels (first run only)" in capsys.readouterr().err


def test_kernel_sources_are_the_modules_the_kernel_imports():
    from bootnav.postproc.ins import fast

    names = {p.name for p in fast.kernel_sources()}
    assert {"fast.py", "measurements.py", "kalman.py", "kernels.py", "riccati.py", "smoother.py", "layout.py"} <= names
    assert not names & {"stream.py", "filter.py", "reference.py"}  # Python drivers: an edit needs no recompile
    stamp = fast.filter_chunk._cache._cache_file._source_stamp
    assert stamp[1] == fast.key_cache_on_sources([], fast.kernel_sources())


def test_from_still_applies_the_accelerometer_calibration(walks, tmp_path):
    """With ``calibration.accel_calibration_file`` set, pushed raw samples are calibrated as process
    calibrates the whole record: the path is run_filter's on the calibrated samples."""
    import dataclasses
    import json

    from bootnav.postproc.calibration import apply_accel_calibration

    t, acc, gyr, stance, _, sat = walks["sim-stairs"]
    cal_file = tmp_path / "cal.json"
    cal_file.write_text(json.dumps({"bias_mps2": [0.05, -0.08, 0.12],
                                    "matrix": [[1.01, 0.002, 0.0], [0.0, 0.99, -0.003], [0.001, 0.0, 1.004]]}))
    settings = ProcessSettings()
    settings = dataclasses.replace(settings, calibration=dataclasses.replace(
        settings.calibration, accel_calibration_file=str(cal_file)))
    dt = time_base(t).nominal_dt_s
    k = int(np.searchsorted(t, t[0] + 5.0))
    nav = StreamNavigator.from_still(settings, 1.0 / dt, t[:k], acc[:k], gyr[:k])
    parts = [nav.push(t[i:i + 500], acc[i:i + 500], gyr[i:i + 500], stance[i:i + 500], sat[i:i + 500])
             for i in range(0, t.shape[0], 500)]
    rows = NavRows.concatenate(parts + [nav.finish()])
    g = settings.calibration.gravity()
    acc_cal = apply_accel_calibration(acc, str(cal_file))
    init = initial_alignment(t[:k], acc_cal[:k], gyr[:k], settings.calibration, g)
    assert np.abs(nav.init_state.q_nb - init.q_nb).max() == 0.0
    sol = run_filter(t, acc_cal, gyr, stance, init, g, settings.filter, saturated=sat)
    _assert_same(rows, sol, 15)
