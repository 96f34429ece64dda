"""What makes a long ``bootnav process`` fast without changing its result: light start-up imports, the simulator's
lazy names, the numpy peak finder of ``selftune.gait_period``, and the timing probes bounded to the first level
strides of a long recording."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from bootnav.core.runs import runs
from bootnav.errors import InputError
from bootnav.postproc import selftune as S
from bootnav.postproc.calibration import CalibrationSettings, initial_alignment
from bootnav.postproc.detectors import DetectorSettings, detect_stance
from bootnav.postproc.ins import FilterSettings, run_filter

G = CalibrationSettings().gravity()


def _fresh(code: str) -> str:
    """stdout of ``code`` run by a fresh interpreter (nothing imported yet)."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60).stdout


def test_start_up_imports_no_scipy_for_the_parser_nor_scipy_signal_for_process():
    # building the parser (`bootnav --help`) needs no scipy; the process path no scipy.signal (~0.7 s: it loads
    # scipy.stats), which only the stance fallback's cycle-minimum candidate uses
    out = _fresh("import sys\nimport bootnav.cli as c\nc.build_parser()\nprint(any(m.startswith('scipy') for m in "
                 "sys.modules))\nimport bootnav.postproc.pipeline, bootnav.postproc.outputs\n"
                 "print('scipy.signal' in sys.modules, 'matplotlib' in sys.modules)")
    assert out.split() == ["False", "False", "False"]


def test_the_block_passes_gait_period_imports_no_scipy_signal():
    # the gait period of the block passes (``selftune.GaitPeriodAccumulator``) convolves by scipy.fft
    out = _fresh("import sys\nimport numpy as np\nfrom bootnav.postproc.selftune import GaitPeriodAccumulator\n"
                 "acc = GaitPeriodAccumulator(0.005)\nfor _ in range(3):\n    acc.push(np.random.rand(3000, 3))\n"
                 "acc.finish()\nprint('scipy.signal' in sys.modules)")
    assert out.split() == ["False"]


@pytest.mark.parametrize("first", ["import bootnav.simulator.simulate", "from bootnav.simulator import writers",
                                   "import bootnav.simulator"])
def test_simulator_simulate_is_the_function_whatever_is_imported_first(first):
    out = _fresh(f"{first}\nimport bootnav.simulator as s\nfrom bootnav.simulator import simulate\n"
                 "from bootnav.simulator.simulate import LongSimulation\n"
                 "print(callable(s.simulate), s.simulate is simulate, type(s.simulate).__name__, s.MOUNTS is not None)")
    assert out.split() == ["True", "True", "function", "True"]


def test_local_maxima_are_scipy_find_peaks():
    from scipy.signal import find_peaks

    from bootnav.core.peaks import local_maxima

    rng = np.random.default_rng(7)
    for k in range(2000):
        x = rng.integers(0, 4, int(rng.integers(0, 40))).astype(float)  # plateaus of every length, at the ends too
        if k % 2:
            x = rng.normal(size=x.size)
        if k % 5 == 0 and x.size:
            x[rng.integers(0, x.size, 2)] = np.nan
        assert np.array_equal(local_maxima(x), find_peaks(x)[0])


@pytest.fixture(scope="module")
def loop():
    from bootnav import simulator as sim

    res = sim.simulate("rectangle", seed=2, rate_hz=200.0)
    t, a, w = res.t_s, np.asarray(res.acc_mps2, float), np.asarray(res.gyro_radps, float)
    init = initial_alignment(t, a, w, CalibrationSettings(), G)
    stance = np.asarray(detect_stance(t, a, w, DetectorSettings(), G).stance, bool)
    return t, a, w, stance, init


def test_timing_probes_of_a_long_record_use_its_first_level_strides(loop):
    t, a, w, stance, init = loop
    fs = FilterSettings()
    whole = S.level_timing_offset(t, a, w, stance, init, G, fs)
    n_phases = len(runs(stance)[0])
    # a bound above the recording's phases: the whole recording, bit for bit as without a bound
    assert S.level_timing_offset(t, a, w, stance, init, G, fs, max_level_strides=n_phases) == whole
    # a bound of K level strides: the forward filter is causal, so the probes over the first 2K + 1 stance
    # phases give the first K level strides of whole-record probes (to rounding: their time base is the part's)
    k = 8
    assert 2 * k + 1 < n_phases and whole["n_level"] > k
    got = S.level_timing_offset(t, a, w, stance, init, G, fs, max_level_strides=k)
    assert got["n_level"] == k and got["probe_s"] < whole["probe_s"]
    for d, key in ((-0.002, "m_minus"), (0.002, "m_plus")):
        nav = run_filter(t, S.rotate_specific_force(a, w, d), w, stance, init, G,
                         replace(fs, smoother="none", level_height=False))
        assert got[key] == pytest.approx(S.level_stride_dz(t, np.asarray(nav.pos_n), stance, max_level_strides=k)[0],
                                         abs=1e-12)
    with pytest.raises(InputError, match="timing_max_level_strides: 0 level strides"):
        S.level_timing_offset(t, a, w, stance, init, G, fs, max_level_strides=0)
