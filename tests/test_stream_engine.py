"""The incremental engine (``bootnav.postproc.ins.stream.StreamNavigator``): any chunking gives the whole-array
``run_filter`` result; rows are final when returned and memory is bounded; external measurements; the numba
cache is keyed on every module the kernel inlines."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
import threading
from dataclasses import fields

import numpy as np
import pytest

import bootnav
from bootnav.core.timebase import time_base
from bootnav.errors import InputError
from bootnav.postproc.calibration import initial_alignment
from bootnav.postproc.detectors import DetectorSettings, detect_stance
from bootnav.postproc.ins import FilterSettings, run_filter
from bootnav.postproc.ins.stream import _RING_CAPS, NavRows, StreamNavigator
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
    # the smoother's buffers: a fixed ring of segment caps, whatever the record's length
    assert nav._buf_post.shape[0] == _RING_CAPS * nav.prm.max_segment and nav.prm.max_segment == math.ceil(0.3 / dt)
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

    init = type("I", (), {"q_nb": [1.0, 0, 0, 0], "gyro_bias_b": np.zeros(3)})()
    StreamNavigator.from_initial_state(init, G, 0.01)  # compiles or loads the kernels, whatever the cache holds
    told = []
    with fast.compile_notice(lambda: told.append(1)):
        StreamNavigator.from_initial_state(init, G, 0.01)
    assert told == []  # compiled or loaded in this process by now: no notice (independent of numba's cache)
    code = ("from bootnav.postproc.ins import fast; "
            "print(fast.cached_on_disk(fast.filter_chunk), fast.cached_on_disk(fast.close_segment))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120,
                         env=dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "empty")), cwd=REPO).stdout
    assert out.split() == ["False", "False"]


def test_process_says_when_it_compiles(tmp_path, monkeypatch, capsys):
    """`bootnav process` shows "compiling numerical kernels ... (first run ...)" once when the kernels must be
    compiled (forced here: the machine's cache is warm), and not otherwise."""
    from bootnav.cli import main
    from bootnav.postproc.ins import fast

    rec = REPO / "recordings" / "sim_paper-stairs.h5"
    assert main(["process", str(rec), "--out", str(tmp_path / "a"), "--no-plots"]) == 0
    assert "compiling" not in capsys.readouterr().err
    monkeypatch.setattr(fast, "_needs_compiling", lambda: True)
    assert main(["process", str(rec), "--out", str(tmp_path / "b"), "--no-plots"]) == 0
    said = [ln for ln in capsys.readouterr().err.splitlines() if "compiling" in ln]
    assert len(said) == 1 and "bootnav process: compiling numerical kernels" in said[0] and "first run" in said[0]


def test_kernel_sources_are_the_modules_the_kernel_imports():
    from bootnav.postproc.ins import fast

    names = {p.name for p in fast.kernel_sources()}
    assert {"fast.py", "measurements.py", "kalman.py", "kernels.py", "riccati.py", "smoother.py", "layout.py"} <= names
    assert not names & {"stream.py", "filter.py", "filterpy_engine.py"}  # Python drivers: an edit needs no recompile
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


def _fields_bits(rows):
    return {f.name: getattr(rows, f.name) for f in fields(NavRows) if f.name != "start"}


@pytest.mark.parametrize("cap_s", [0.3, None])
def test_smoothing_thread_gives_the_same_bits(walks, monkeypatch, cap_s):
    """One whole-record push smooths most closed segments in the smoothing thread (the ring of segment
    buffers wraps around several times with a 0.3 s cap); pushes of 7 samples smooth what closed since the
    last hand-over in the pushing thread, and without the thread everything is smoothed there. All give the
    same bits (signs of zeros included), and no smoothing thread outlives a push."""
    from bootnav.postproc.ins import fast, stream

    t, acc, gyr, stance, init, sat = walks["xio-real"]
    fs = FilterSettings() if cap_s is None else FilterSettings(smoother_max_segment_s=cap_s)
    where = []
    smooth = fast.smooth_segments

    def spy(closed, *args):
        where.append((threading.current_thread().name, int(closed[:, 1].sum())))
        return smooth(closed, *args)

    StreamNavigator.from_initial_state(init, G, 0.01, fs)  # the kernels compiled (or loaded) before the spy
    monkeypatch.setattr(fast, "ensure_compiled", lambda nav: 0.0)
    monkeypatch.setattr(fast, "smooth_segments", spy)
    monkeypatch.setattr(stream, "SMOOTHING_THREAD", True)  # whatever the machine's load
    whole, nav, _ = _stream(walks["xio-real"], fs, t.shape[0])
    threaded = sum(m for name, m in where if name.startswith("bootnav-smoother"))
    assert threaded > 0.5 * t.shape[0]  # most segments were smoothed beside the filter
    if cap_s is not None:
        assert threaded > 3 * nav._buf_post.shape[0]  # the ring wrapped around
    assert not [th for th in threading.enumerate() if th.name.startswith("bootnav-smoother")]
    where.clear()
    small, nav7, _ = _stream(walks["xio-real"], fs, 7)
    assert any(name == threading.current_thread().name for name, _ in where)  # the end of a push: here
    assert nav7.info["smoother_segments"] == nav.info["smoother_segments"]
    assert nav7.info["smoother_skipped_steps"] == nav.info["smoother_skipped_steps"]
    monkeypatch.setattr(stream, "SMOOTHING_THREAD", False)
    where.clear()
    alone, _, _ = _stream(walks["xio-real"], fs, t.shape[0])
    assert where and all(name == threading.current_thread().name for name, _ in where)
    for other in (small, alone):
        for name, a in _fields_bits(whole).items():
            b = _fields_bits(other)[name]
            assert np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b)), name


def test_one_core_runs_the_same_code_without_deadlock(walks, tmp_path):
    """A fresh process confined to one core (sched_setaffinity) with the smoothing thread forced on runs the
    filter and the smoothing thread in turn: it finishes (no deadlock) with the same bits as this process."""
    if not hasattr(os, "sched_setaffinity"):
        pytest.skip("no sched_setaffinity on this platform")
    t, acc, gyr, stance, init, sat = walks["sim-stairs"]
    fs = FilterSettings(smoother_max_segment_s=0.3)
    rows, _, _ = _stream(walks["sim-stairs"], fs, t.shape[0])
    np.savez(tmp_path / "walk.npz", t=t, acc=acc, gyr=gyr, stance=stance, sat=sat, q=init.q_nb, bg=init.gyro_bias_b,
             ba=getattr(init, "acc_bias_b", np.zeros(3)))
    code = textwrap.dedent(f"""
        import os, sys
        import numpy as np
        os.sched_setaffinity(0, {{min(os.sched_getaffinity(0))}})
        from bootnav.core.timebase import time_base
        from bootnav.postproc.ins import FilterSettings
        from bootnav.postproc.ins import stream
        from bootnav.postproc.ins.stream import NavRows, StreamNavigator
        stream.SMOOTHING_THREAD = True
        w = np.load(sys.argv[1])
        init = type("I", (), dict(q_nb=w["q"], gyro_bias_b=w["bg"], acc_bias_b=w["ba"]))()
        nav = StreamNavigator.from_initial_state(init, {G!r}, time_base(w["t"]).nominal_dt_s,
                                                 FilterSettings(smoother_max_segment_s=0.3))
        r = NavRows.concatenate([nav.push(w["t"], w["acc"], w["gyr"], w["stance"], saturated=w["sat"]), nav.finish()])
        np.savez(sys.argv[2], pos=r.pos_n, q=r.q_nb, vel=r.vel_n)
        """)
    subprocess.run([sys.executable, "-c", code, str(tmp_path / "walk.npz"), str(tmp_path / "out.npz")], cwd=REPO,
                   check=True, timeout=120)
    one = np.load(tmp_path / "out.npz")
    for name, a in (("pos", rows.pos_n), ("q", rows.q_nb), ("vel", rows.vel_n)):
        assert np.array_equal(one[name], a) and np.array_equal(np.signbit(one[name]), np.signbit(a)), name


@pytest.mark.parametrize("n", [9, 15])
def test_smoother_kernel_restarts_where_the_prior_is_not_positive_definite(n):
    """``smoother.rts_backward`` on a segment laid across the end of its ring of buffers: where P⁻(j+1) is
    not positive definite (two such steps, one in each slot of the paired factorisation) it counts the step,
    leaves row j as filtered and restarts from zero, i.e. it equals the readable ``rts_backward_numpy`` on the
    pieces between those steps (1e-12 relative: different summation order); the same segment laid out
    without wrapping gives the same bits."""
    from bootnav.postproc.ins.smoother import rts_backward, rts_backward_numpy

    rng = np.random.default_rng(7)
    m, cap, b0 = 42, 64, 50  # buffer rows 50..63 then 0..27; steps paired (40, 39), ..., (2, 1), then 0 alone
    a = rng.normal(size=(m, n, n))
    p_post = a @ a.transpose(0, 2, 1) + n * np.eye(n)
    p_pred = p_post + 0.1 * np.eye(n)
    p_post += 1e-3 * rng.normal(size=(m, n, n))  # not exactly symmetric, as the filter's P
    bad_steps = (30, 11)  # steps j whose P⁻(j+1) is not positive definite
    for j in bad_steps:
        p_pred[j + 1, 4, 4] = -1.0
    fpar = np.concatenate([np.full((m, 1), 0.005), rng.normal(size=(m, 3)),
                           np.array([np.linalg.qr(rng.normal(size=(3, 3)))[0].ravel() for _ in range(m)])], axis=1)
    dx_upd = 1e-2 * rng.normal(size=(m, n))
    low = np.tril_indices(n)

    def run(first, capacity):
        rows = (first + np.arange(m)) % capacity
        post, pred = np.zeros((capacity, n, n)), np.zeros((capacity, n * (n + 1) // 2))
        fp, dxu = np.zeros((capacity, 13)), np.zeros((capacity, n))
        post[rows], pred[rows], fp[rows], dxu[rows] = p_post, p_pred[:, low[0], low[1]], fpar, dx_upd
        out = [np.zeros((m + 3, 3)) for _ in range(4)]
        q = np.tile([1.0, 0.0, 0.0, 0.0], (m + 3, 1))
        upd = np.zeros(capacity, dtype=np.int64)
        upd[rows] = -1  # every row has a correction, from an update of any H (the smoother factorises P⁻)
        bufs = _buffers(post, pred, fp, dxu, upd)
        bad = rts_backward(bufs, first, m, n, 3, out[0], out[1], q, out[2], out[3])
        return bad, out, q

    bad, (pos, vel, ba, bg), q = run(b0, cap)
    assert bad == len(bad_steps)
    expected = np.zeros((m, n))
    edges = [0, *sorted(j + 1 for j in bad_steps), m]
    for lo, hi in zip(edges[:-1], edges[1:]):
        expected[lo:hi] = rts_backward_numpy(p_post[lo:hi], p_pred[lo:hi], fpar[lo:hi], dx_upd[lo:hi], hi - lo, n)
    scale = np.abs(expected).max()
    assert np.all(pos[:3] == 0.0) and np.all(pos[3 + np.array(bad_steps)] == 0.0)
    assert np.abs(pos[3:] - expected[:, 0:3]).max() <= 1e-12 * scale
    assert np.abs(vel[3:] - expected[:, 3:6]).max() <= 1e-12 * scale
    if n == 15:
        assert np.abs(bg[3:] - expected[:, 12:15]).max() <= 1e-12 * scale
    bad2, out2, q2 = run(0, m)
    assert bad2 == bad and np.array_equal(q2, q)
    assert all(np.array_equal(u, v) for u, v in zip(out2, (pos, vel, ba, bg)))


@pytest.mark.parametrize("n", [9, 15])
def test_smoother_needs_no_prior_at_a_row_without_update(n):
    """The filter stores P⁻ only at rows with a measurement update (``SmootherBuffers.updates``); at the others
    P⁻ = P⁺. A segment ending on such rows (closed at its length cap mid-swing, or at the record's end), with a
    run of them inside too, smooths as the readable ``rts_backward_numpy`` given P⁻ everywhere (1e-12
    relative), though the unstored P⁻ rows hold NaN."""
    from bootnav.postproc.ins.smoother import rts_backward, rts_backward_numpy

    rng = np.random.default_rng(11)
    m = 40
    no_update = np.zeros(m, bool)
    no_update[12:18] = no_update[33:] = True
    a = rng.normal(size=(m, n, n))
    p_pred = a @ a.transpose(0, 2, 1) + n * np.eye(n)
    p_post = p_pred - 0.1 * np.eye(n) + 1e-3 * rng.normal(size=(m, n, n))  # not exactly symmetric
    p_post[no_update] = p_pred[no_update]
    fpar = np.concatenate([np.full((m, 1), 0.005), rng.normal(size=(m, 3)),
                           np.array([np.linalg.qr(rng.normal(size=(3, 3)))[0].ravel() for _ in range(m)])], axis=1)
    dx_upd = 1e-2 * rng.normal(size=(m, n))
    dx_upd[no_update] = 0.0
    low = np.tril_indices(n)
    pred_tri = p_pred[:, low[0], low[1]]
    pred_tri[no_update] = np.nan  # never written by the filter
    out = [np.zeros((m, 3)) for _ in range(4)]
    q = np.tile([1.0, 0.0, 0.0, 0.0], (m, 1))
    updates = np.where(no_update, 0, -1)  # the others: an update of any H
    bad = rts_backward(_buffers(p_post, pred_tri, fpar, dx_upd, updates), 0, m, n, 0, out[0], out[1], q, out[2], out[3])
    assert bad == 0
    expected = rts_backward_numpy(p_post, p_pred, fpar, dx_upd, m, n)
    scale = np.abs(expected).max()
    assert scale > 0 and np.isfinite(out[0]).all()
    assert np.abs(out[0] - expected[:, 0:3]).max() <= 1e-12 * scale
    assert np.abs(out[1] - expected[:, 3:6]).max() <= 1e-12 * scale


def _buffers(post, pred_tri, fpar, dx_upd, updates):
    """``fast.SmootherBuffers`` of the given rows, no update of the filter's own listed."""
    from bootnav.postproc.ins import fast
    from bootnav.postproc.ins.measurements import N_KINDS

    cap, n = dx_upd.shape
    return fast.SmootherBuffers(post, np.ascontiguousarray(pred_tri), fpar, dx_upd, np.asarray(updates, np.int64),
                                np.zeros((cap, N_KINDS, 3, n)), np.zeros((cap, N_KINDS, 3)),
                                np.zeros((cap, N_KINDS, 2), dtype=np.int64))
