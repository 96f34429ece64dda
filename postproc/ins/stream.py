"""Incremental navigation: the fast engine's ZUPT filter + segment RTS smoother, pushed chunk by chunk.

``StreamNavigator`` is THE engine: ``run_filter`` (``run_fast`` here) pushes a whole record through it, the
live view and the block passes of a long recording (``passes.BlockPasses``) push chunks as they arrive or
are read. Push samples in chunks of any size (1 sample, 7, 10⁵, ...); each ``push`` returns the output rows
that became final, with their absolute sample index; ``finish`` returns the rest. The rows are identical for
every chunking (the kernel runs the same arithmetic on the same samples in the same order; tests/test_stream_engine.py).

**When a row is final.** The smoother corrects the rows of its open segment (from the first swing sample
after a stance phase to the last sample of the next one, at most ``smoother_max_segment_s``) when the segment
closes, i.e. when the first sample after it arrives; until then those rows are held back. Without the
smoother a row is final once the next sample is filtered (``apply_measurement`` may still change the last
one). Before filtering, a stance sample waits until its ZUPT decision is known: the onset delay
(``prepare.delay_zupt_onsets``) removes min(``zupt_onset_delay_s``, ``zupt_onset_max_fraction`` × phase
duration) from the start of each stance phase, which is known once the phase has ended or lasted
``zupt_onset_delay_s / zupt_onset_max_fraction`` (0.45 s by default). Memory is bounded by the chunk size +
``smoother_max_segment_s`` + that look-ahead, never by the record length.

**What ``process`` computes over the whole recording and a stream user cannot** (and what to do instead):

* the nominal sample period Δt₀ (median step of the record; it scales the per-sample noise and the segment
  cap): give the device's nominal rate (``rate_hz``);
* the initial alignment (still period found in the first ``still_search_s``, averaged up to
  ``max_still_s``): ``from_still`` aligns on the still seconds you give it; give the whole initial rest for
  the same attitude and gyro bias as ``process``;
* the vertical timing self-calibration τ (``selftune.level_timing_offset``, from the level strides of the
  whole record): push the raw specific force (τ = 0) or, for a boot calibrated before, the specific force
  rotated by its τ (``selftune.rotate_specific_force`` is per sample, so it can be applied chunk-wise);
* the stance fallback (another detector when the configured one fails on the record): use the configured
  detector (``bootnav.postproc.detectors.stream.StreamStance``);
* the sensor calibration and the saturation mask are per sample: ``from_still`` applies the calibration file
  the settings name (``calibration.resolve_calibration``; a stream has no device id, so no store match, and
  no temperature: the bias at the reference temperature) to every pushed chunk; a user who has the device id
  and the temperature calibrates the chunks with ``calibration.apply_calibration`` and gives settings with
  ``sensor_calibration = "none"`` (as the live view does); pass the saturation bits to ``push``.

**Aiding from outside** (two-boot fusion): ``position_n`` / ``position_cov_n`` are the estimate and its 3×3
covariance at the last filtered sample (``last_index``); ``apply_measurement(z, H, R)`` is a Kalman update of
the error state there (z = H δx + ν, δx = x_true − x̂, e.g. z = p_measured − p̂, H = [I 0]), recorded in the
smoother's buffers like the ZUPT so the backward pass stays consistent [RTS1965; Colomar2012].

Each push costs ~0.1 ms of Python besides the samples' own time: push chunks of 10 ms or more of samples.
Within a long push the smoother runs beside the filter when a core is free (``SMOOTHING_THREAD``): closed
segments go in batches to a smoothing thread (``fast.smooth_segments``, GIL released) while the filter fills
the other half of a fixed ring of buffers (the filter waits when the ring is full); at the end of the push the
rest is smoothed and the thread ends, so the rows returned are final and no thread outlives a push. Without
the thread the kernel smooths each segment as soon as it closes. The arithmetic is the same in either thread:
so is the result.

API-STABLE

Usage (a stream user; ``source`` yields chunks of every sample from the first, the initial rest included)::

    from bootnav.postproc.calibration import stance_reference
    from bootnav.postproc.detectors.stream import StreamStance
    from bootnav.postproc.ins.stream import StreamNavigator
    from bootnav.postproc.settings import ProcessSettings

    settings = ProcessSettings()
    nav = StreamNavigator.from_still(settings, rate_hz, t_still, acc_still, gyro_still)  # the first seconds
    bias, g_rest = stance_reference(nav.init_state, nav.gravity)  # the rest as the sensor read it
    stance = StreamStance(settings.detector, rate_hz, gravity=g_rest, gyro_bias_b=bias)
    feed = lambda chunks: [nav.push(c.t_s, c.acc_b, c.gyro_b, c.stance, c.saturated) for c in chunks]
    for t, acc, gyr, sat in source:
        for rows in feed(stance.push(t, acc, gyr, sat)):
            draw(rows.index, rows.pos_n)                  # final rows, with their absolute sample indices
    for rows in feed(stance.finish()) + [nav.finish()]:
        draw(rows.index, rows.pos_n)
"""

from __future__ import annotations

import os
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, fields

import numpy as np

from bootnav.core.runs import runs
from bootnav.postproc.ins.increments import previous_rows, sculling_coning
from bootnav.core.timebase import GAP_FACTOR
from bootnav.errors import InputError
from bootnav.postproc.ins import fast
from bootnav.postproc.ins.layout import (BIAS_ACC, BIAS_GYRO, ERR_BA, ERR_BG, ERR_P, ERR_TH, ERR_V, HDE_GATE,
                                         HDE_HAVE_PREV, HDE_REF_HEADING, POS, QUAT, VEL, initial_nominal_state)
from bootnav.postproc.ins.measurements import HEADING_AID, LEVEL_HEIGHT, N_KINDS, ZUPT, active_flags
from bootnav.postproc.ins.prepare import (MAX_LISTED_GAPS, FilterSetup, gated_chunks, prepare_filter,
                                          saturation_variance)
from bootnav.postproc.ins.settings import FilterSettings

_ROWS3 = ("pos_n", "vel_n", "acc_bias_b", "gyro_bias_b", "pos_sigma_n")
_PUSH_MAX = 65_536  # samples per push in run_fast (bounded temporaries)
# the smoother's segment buffers: a ring of this many segment caps (prm.max_segment samples each); closed
# segments go to a smoothing thread in batches of at least half a cap's worth of samples, so the filter fills
# one half of the ring while the other is smoothed. Memory and speed only (the result is the same): a larger
# ring spreads the buffers over more cache, smaller batches cost more Python (docs/tuning-log.md)
_RING_CAPS = 2
_BATCH_CAPS = 0.5
# smooth in a thread beside the filter? None: when a core is free as the push starts (runnable
# tasks, this one included, ≤ usable cores − 1; on a busy machine, or in one of eval's worker processes, a
# second thread gains no time and costs the cache traffic of handing the buffers over); True / False: always /
# never. Without the thread the kernel smooths each segment as it closes (its buffers still in the cache). The
# result is the same either way.
SMOOTHING_THREAD: bool | None = None


def _runnable_tasks() -> int:
    """Tasks running or ready to run on the machine now, this one included (Linux ``/proc/loadavg``; 1 where
    it cannot be read)."""
    try:
        with open("/proc/loadavg", encoding="ascii") as f:
            return int(f.read().split()[3].split("/")[0])
    except (OSError, ValueError, IndexError):
        return 1


def _smoothing_workers() -> int:
    """Threads to smooth closed segments in, 0 for the pushing thread itself (``SMOOTHING_THREAD``)."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    use = SMOOTHING_THREAD
    if use is None:
        use = cores >= 2 and _runnable_tasks() <= cores - 1
    return max(1, min(2, cores - 1)) if use else 0  # two with three cores or more


@dataclass
class NavRows:
    """Consecutive final output rows of a ``StreamNavigator`` (SI, nav frame ENU, q_nb wxyz body -> nav).

    ``start`` is the absolute sample index (0 = the first pushed sample) of the first row; ``stance`` is the
    pushed stance mask, ``zupt`` the ZUPT mask the filter applied (after the onset delay). The biases are the
    initial ones throughout with 9 states.
    """

    start: int
    t_s: np.ndarray  # (m,)
    pos_n: np.ndarray  # (m, 3)
    vel_n: np.ndarray  # (m, 3)
    q_nb: np.ndarray  # (m, 4)
    acc_bias_b: np.ndarray  # (m, 3)
    gyro_bias_b: np.ndarray  # (m, 3)
    pos_sigma_n: np.ndarray  # (m, 3), the filter's (not smoothed) 1-σ
    pos_cov_en: np.ndarray  # (m,), the filter's east-north position covariance P_EN, m²
    stance: np.ndarray  # (m,) bool
    zupt: np.ndarray  # (m,) bool

    def __len__(self) -> int:
        return int(self.t_s.shape[0])

    @property
    def index(self) -> np.ndarray:
        """Absolute sample index of every row."""
        return np.arange(self.start, self.start + len(self), dtype=np.int64)

    @classmethod
    def empty(cls, start: int) -> NavRows:
        """No rows, at absolute index ``start``."""
        z3 = np.zeros((0, 3))
        return cls(start, np.zeros(0), z3, z3.copy(), np.zeros((0, 4)), z3.copy(), z3.copy(), z3.copy(), np.zeros(0),
                   np.zeros(0, bool), np.zeros(0, bool))

    @classmethod
    def concatenate(cls, parts: list[NavRows]) -> NavRows:
        """Consecutive parts as one (ValueError if they are not consecutive)."""
        parts = [p for p in parts if len(p)] or parts[:1]
        if not parts:
            raise ValueError("no rows to concatenate")
        for a, b in zip(parts[:-1], parts[1:]):
            if a.start + len(a) != b.start:
                raise ValueError(f"rows are not consecutive: {a.start}+{len(a)} then {b.start}")
        return cls(parts[0].start, *(np.concatenate([getattr(p, f.name) for p in parts])
                                     for f in fields(cls) if f.name != "start"))


def _riccati_gain(zupt_gain) -> fast.RiccatiGain:
    """The kernel's form of the paper mode's gain (``riccati.ZuptGain``; identity and zeros without it)."""
    if zupt_gain is None:
        return fast.RiccatiGain(np.eye(3), np.zeros(3), np.zeros((6, 3)))
    return fast.RiccatiGain(*(np.ascontiguousarray(a, dtype=np.float64) for a in (zupt_gain.U, zupt_gain.lam,
                                                                                     zupt_gain.T)))


class StreamNavigator:
    """The ZUPT error-state filter (+ segment RTS smoother) over samples pushed in chunks (module docstring).

    Build it with ``from_still`` (a stream user: settings, rate and the first still seconds) or
    ``from_initial_state`` (an initial state and gravity you already have); the constructor itself takes what
    ``prepare.prepare_filter`` prepares.
    ``kernel_model`` (``fast.FilterModel``) is what the kernel computes with: the kernel parameters, the active
    measurement models, the number of error states and the paper mode's gain.

    Parameters
    ----------
    settings : FilterSettings
        Validated filter settings.
    setup : prepare.FilterSetup
        Initial state and covariance, paper-mode gain, kernel parameters (``prepare.prepare_filter``).
    nominal_dt_s : float
        Nominal sample period Δt₀, s.
    apply_onset_delay : bool
        True: the pushed ``stance`` is a detector's mask and the ZUPT onset delay is applied here (as
        ``run_filter`` does); False: it is already the ZUPT mask.
    acc_calibration : bootnav.core.sensorcal.SensorCalibration or calibration.AccelCalibration, optional
        Applied to every pushed chunk (specific force, and the rate for a sensor calibration).
    """

    def __init__(self, settings: FilterSettings, setup, nominal_dt_s: float, *, apply_onset_delay: bool = True,
                 acc_calibration=None):
        self.settings = settings
        self.setup = setup
        self.prm = prm = setup.prm
        self.nominal_dt_s = float(nominal_dt_s)
        self.gravity = float(prm.gravity)
        self.n = n = settings.n_states
        self._onset = apply_onset_delay and settings.zupt_onset_delay_s > 0 and settings.zupt_onset_max_fraction > 0
        self._acc_cal = acc_calibration
        self._active = active_flags(settings)
        self.kernel_model = fast.FilterModel(prm, self._active, n, _riccati_gain(setup.zupt_gain))
        self._st = initial_nominal_state(setup.q0_nb, setup.acc_bias0_b, setup.gyro_bias0_b,
                                         settings.heading_aid_reference_rad)
        self._P = np.array(setup.P0, dtype=np.float64, order="C", copy=True)
        self._state = fast.FilterState(self._st, self._P)
        nb = _RING_CAPS * prm.max_segment if prm.smooth else 1
        self._buf_post = np.empty((nb, n, n))
        self._buf_pred = np.empty((nb, n * (n + 1) // 2))  # lower triangle of P⁻ (for apply_measurement's rows)
        self._buf_fpar = np.empty((nb, 13))
        self._buf_dx = np.empty((nb, n))
        self._buf_updates = np.zeros(nb, dtype=np.int64)
        self._bufs = fast.SmootherBuffers(self._buf_post, self._buf_pred, self._buf_fpar, self._buf_dx,
                                          self._buf_updates, np.empty((nb, N_KINDS, 3, n)), np.empty((nb, N_KINDS, 3)),
                                          np.empty((nb, N_KINDS, 2), dtype=np.int64))
        self._seg = np.zeros(fast.N_SEG, dtype=np.int64)
        self._closed = np.zeros((nb // 2 + 1, 3), dtype=np.int64)  # closed segments hold ≥ 2 buffer rows each
        self._book = fast.SegmentBook(self._seg, self._closed, max(1, int(_BATCH_CAPS * prm.max_segment)))
        self._book_inline = fast.SegmentBook(self._seg, self._closed, 0)  # no thread: the kernel smooths
        self._in_flight: deque = deque()  # (future, first buffer row) of the batches being smoothed, oldest first
        self._pool = None
        self._workers = None  # smoothing threads of this push (_smoothing_workers), decided as it starts
        self._applied = np.zeros(N_KINDS, dtype=np.int64)
        self._counters = np.zeros(2, dtype=np.int64)
        self._counts = fast.RunCounts(self._applied, self._counters)
        # queue of pushed samples not filtered yet (their ZUPT decision waits for the onset delay)
        self._q_t = np.zeros(0)
        self._q_acc = np.zeros((0, 3))
        self._q_gyro = np.zeros((0, 3))
        self._q_stance = np.zeros(0, dtype=bool)
        self._q_xvar = np.zeros((0, 6))
        self._q_gate = None  # per-sample heading gate (1, 0, NaN = as set) once a push gave one
        self._gate_set = 1.0  # set_heading_gate's flag
        self._n_pushed = 0
        self._n_done = 0  # samples filtered = absolute index of the queue's first sample
        self._t_pushed_last = None
        self._t_done_last = None
        # onset delay: raw stance of the sample before the queue, start time of its stance run, run at sample 0
        self._prev_raw = False
        self._run_t0 = 0.0
        self._run_initial = False
        # paper mode: ZUPT flag of the last filtered sample and time of the last ZUPT sample (open-loop τ)
        self._prev_zupt = False
        self._last_zupt_t = 0.0
        # "increments" strapdown: the last filtered sample's (f_b, ω_b, Δt) before the corrections
        self._increments = settings.strapdown == "increments"
        self._prev_sample = None
        # rows filtered but not final: _out[name][_out_from:_out_filled], row _out_from = sample _out_start
        self._out = None
        self._out_from = 0
        self._out_filled = 0
        self._out_start = 0
        self._finished = False
        self._n_external = 0
        self._n_duplicates = 0
        self._n_gaps = 0
        self._gaps: list[tuple[int, float]] = []  # (sample index, Δt) of the first MAX_LISTED_GAPS gaps
        self._max_dt = 0.0
        self._n_onset_skipped = 0  # stance samples the onset delay kept from the ZUPT
        self._n_inflated = 0  # saturated samples given extra process noise
        self.init_state = None  # the alignment, when built by from_still
        self.compile_s = fast.ensure_compiled(self.kernel_model)
        self.run_s = 0.0

    # ------------------------------------------------------------------------------------------ construction
    @classmethod
    def from_initial_state(cls, init, gravity: float, nominal_dt_s: float, settings: FilterSettings | None = None,
                           *, acc_calibration=None) -> StreamNavigator:
        """A navigator from an initial state (``run_filter``'s ``init``, e.g. ``calibration.InitialState``).

        Parameters
        ----------
        init : object
            ``q_nb`` (4,) wxyz and ``gyro_bias_b`` (3,) rad/s; optional ``acc_bias_b`` and ``acc_mean_b``.
        gravity : float
            Local gravity magnitude, m/s².
        nominal_dt_s : float
            Nominal sample period, s (1 / the device's rate).
        settings : FilterSettings, optional
            Default ``FilterSettings()``.
        acc_calibration : bootnav.core.sensorcal.SensorCalibration or calibration.AccelCalibration, optional
            Applied to every pushed chunk.

        Returns
        -------
        StreamNavigator
        """
        settings = settings or FilterSettings()
        settings.validate()
        return cls(settings, prepare_filter(init, gravity, settings, nominal_dt_s), nominal_dt_s,
                   acc_calibration=acc_calibration)

    @classmethod
    def from_still(cls, settings, rate_hz: float, t_s, acc_b, gyro_b) -> StreamNavigator:
        """A navigator aligned as ``process`` aligns: on the still seconds given (push them afterwards too).

        Parameters
        ----------
        settings : bootnav.postproc.settings.ProcessSettings
            Its ``calibration`` (gravity, accelerometer calibration file, still-period rules) and ``filter``.
        rate_hz : float
            The device's nominal sample rate, Hz.
        t_s, acc_b, gyro_b : (N,), (N, 3), (N, 3) arrays
            The first samples of the recording, including its initial rest (s, m/s² raw, rad/s).

        Returns
        -------
        StreamNavigator
            ``init_state`` holds the alignment (``calibration.InitialState``, with its warnings).
        """
        from bootnav.postproc.calibration import apply_calibration, initial_alignment, resolve_calibration

        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise InputError(f"rate_hz must be the device's positive sample rate in Hz, got {rate_hz!r}")
        settings.validate()
        cal = settings.calibration
        applied = resolve_calibration(cal)  # no device id: an explicit file or none
        acc_cal = applied.calibration
        acc_b, gyro_b = apply_calibration(applied, np.asarray(acc_b, dtype=np.float64), np.asarray(gyro_b, np.float64))
        gravity = cal.gravity()
        try:
            init = initial_alignment(t_s, acc_b, gyro_b, cal, gravity)
        except ValueError as e:
            raise InputError(f"initial alignment of the stream: {e}; give the first still seconds") from None
        nav = cls.from_initial_state(init, gravity, 1.0 / rate_hz, settings.filter, acc_calibration=acc_cal)
        nav.init_state = init
        return nav

    # --------------------------------------------------------------------------------------------- state
    @property
    def last_index(self) -> int:
        """Absolute index of the last filtered sample (−1 before the first): the one ``position_n`` and
        ``apply_measurement`` refer to. It trails the last pushed sample by the onset-delay look-ahead."""
        return self._n_done - 1

    @property
    def last_t_s(self) -> float | None:
        """Time of the last filtered sample, s (None before the first)."""
        return self._t_done_last

    @property
    def n_pushed(self) -> int:
        """Samples pushed so far."""
        return self._n_pushed

    @property
    def position_n(self) -> np.ndarray:
        """(3,) position at the last filtered sample, m (filtered, not smoothed)."""
        return self._st[POS].copy()

    @property
    def velocity_n(self) -> np.ndarray:
        """(3,) velocity at the last filtered sample, m/s."""
        return self._st[VEL].copy()

    @property
    def q_nb(self) -> np.ndarray:
        """(4,) attitude at the last filtered sample, wxyz."""
        return self._st[QUAT].copy()

    @property
    def position_cov_n(self) -> np.ndarray:
        """(3, 3) covariance of the position error at the last filtered sample, m²."""
        return self._P[ERR_P, ERR_P].copy()

    @property
    def covariance(self) -> np.ndarray:
        """(n, n) error-state covariance at the last filtered sample (δp, δv, δθ[, δb_a, δb_g])."""
        return self._P.copy()

    @property
    def info(self) -> dict:
        """Counters of the run so far (JSON-serialisable); ``zupt_onset_samples_skipped``,
        ``saturated_samples_inflated`` and ``gaps`` (sample index, Δt s; the first ``prepare.MAX_LISTED_GAPS``,
        ``n_gaps`` counts all) as ``run_filter``'s info has them for the whole record."""
        return {
            "n_pushed": self._n_pushed,
            "n_filtered": self._n_done,
            "n_updates": int(self._applied[ZUPT]),
            "heading_aid_updates": int(self._applied[HEADING_AID]),
            "level_height_updates": int(self._applied[LEVEL_HEIGHT]),
            "external_updates": self._n_external,
            "smoother_segments": int(self._counters[fast.SMOOTHER_SEGMENTS]),
            "smoother_skipped_steps": int(self._counters[fast.SMOOTHER_SKIPPED]),
            "smoother_max_segment_samples": self.prm.max_segment,
            "n_duplicates": self._n_duplicates,
            "n_gaps": self._n_gaps,
            "gaps": list(self._gaps),
            "max_dt_s": self._max_dt,
            "zupt_onset_samples_skipped": self._n_onset_skipped,
            "saturated_samples_inflated": self._n_inflated,
            "compile_s": self.compile_s,
            "run_s": self.run_s,
        }

    # ---------------------------------------------------------------------------------------------- push
    def push(self, t_s, acc_b, gyro_b, stance, saturated=None, heading_gate=None) -> NavRows:
        """Add samples; return the rows that became final.

        Parameters
        ----------
        t_s : (m,) array
            Sample times, s, non-decreasing across pushes (m may be 0).
        acc_b : (m, 3) array
            Specific force, body frame, m/s².
        gyro_b : (m, 3) array
            Angular rate, body frame, rad/s.
        stance : (m,) bool array
            A stance detector's decisions for these samples (the ZUPT mask when built with
            ``apply_onset_delay=False``).
        saturated : array, optional
            Saturation mask of these samples (the forms ``prepare.saturation_variance`` accepts).
        heading_gate : (m,) bool array, optional
            The heading aid's per-segment gate of each of these samples (``building.directions``): each
            sample is filtered with its own flag, however long it waits in the onset-delay queue (as
            ``run_filter(heading_gate=…)``); None: the flag ``set_heading_gate`` last set when it is filtered.

        Returns
        -------
        NavRows
            The final rows (possibly none), starting at absolute index ``start``.

        Raises
        ------
        InputError
            Wrong shapes, non-finite values or time going backwards (the absolute sample index is named),
            or a push after ``finish``.
        """
        t_s, acc_b, gyro_b, stance = self._check(t_s, acc_b, gyro_b, stance)
        xvar = saturation_variance(saturated, t_s.shape[0], self.settings)
        if heading_gate is not None or self._q_gate is not None:
            gate = np.full(t_s.shape[0], np.nan)  # NaN: the flag set_heading_gate set
            if heading_gate is not None:
                flags = np.asarray(heading_gate, dtype=bool).reshape(-1)
                if flags.shape != t_s.shape:
                    raise InputError(f"push at sample {self._n_pushed}: heading_gate has {flags.shape[0]} flags for "
                                     f"{t_s.shape[0]} samples: give one per sample")
                gate[:] = flags
            self._q_gate = gate if self._q_gate is None else np.concatenate([self._q_gate, gate])
        if self._acc_cal is not None and t_s.shape[0]:
            from bootnav.postproc.calibration import AccelCalibration, apply_accel_calibration

            if isinstance(self._acc_cal, AccelCalibration):
                acc_b = apply_accel_calibration(acc_b, self._acc_cal)
            else:
                acc_b, gyro_b = self._acc_cal.apply(acc_b, gyro_b)
        return self._push_checked(t_s, acc_b, gyro_b, stance, None if xvar is None else xvar * self.nominal_dt_s)

    def finish(self) -> NavRows:
        """Filter what is still queued, close the last smoother segment and return every remaining row."""
        if self._finished:
            raise InputError("this StreamNavigator is finished; build a new one for another record")
        rows = self._advance(final=True)
        self._finished = True
        return rows

    def enable_heading_aid(self, reference_rad: float) -> None:
        """Switch the dominant-direction heading aid on from the next filtered sample, on the grid at
        ``reference_rad`` (path frame): ``heading_aid = "auto"`` decided causally (``bootnav live``,
        ``building.directions.CausalDirections``)."""
        self._active[HEADING_AID] = True
        self._st[HDE_REF_HEADING] = float(reference_rad)
        self._st[HDE_HAVE_PREV] = 0.0

    def set_heading_gate(self, open_: bool) -> None:
        """Open or close the heading aid's per-segment gate from the next filtered sample (closed: the aid
        keeps its memory of the strides but corrects none; ``building.directions``)."""
        self._gate_set = 1.0 if open_ else 0.0
        self._st[HDE_GATE] = self._gate_set

    def apply_measurement(self, z, H, R) -> None:
        """Kalman update of the error state at the last filtered sample with z = H δx + ν, ν ~ N(0, R).

        δx = x_true − x̂ = (δp_n, δv_n, δθ_n[, δb_a, δb_g]) (``filter.py``); e.g. a position fix p:
        z = p − ``position_n``, H = [I₃ 0]. Joseph form; δx is injected into the nominal state like the
        ZUPT's (p, v, biases additive, q ← exp(δθ/2) ⊗ q) and recorded in the smoother's buffers (added to that
        sample's correction, its posterior covariance replaced), so the RTS backward pass spreads it back
        over the open segment.

        Parameters
        ----------
        z : (m,) array
            Measurement of the error state.
        H : (m, n) array
            Measurement matrix (n = 9 or 15 error states).
        R : (m, m) array
            Measurement noise covariance, symmetric positive definite.
        """
        if self._finished or self._n_done == 0:
            raise InputError("apply_measurement needs a filtered sample and an unfinished navigator "
                             f"({self._n_done} filtered, finished={self._finished})")
        n = self.n
        z = np.atleast_1d(np.asarray(z, dtype=np.float64))
        H = np.atleast_2d(np.asarray(H, dtype=np.float64))
        R = np.atleast_2d(np.asarray(R, dtype=np.float64))
        m = z.shape[0]
        if z.ndim != 1 or H.shape != (m, n) or R.shape != (m, m):
            raise InputError(f"apply_measurement: expected z (m,), H (m, {n}), R (m, m); got {z.shape}, {H.shape}, "
                             f"{R.shape}")
        if not (np.isfinite(z).all() and np.isfinite(H).all() and np.isfinite(R).all()):
            raise InputError("apply_measurement: z, H and R must be finite")
        P = self._P
        S = H @ P @ H.T + R
        try:
            K = np.linalg.solve(S, H @ P).T  # P Hᵀ S⁻¹ (P, S symmetric)
        except np.linalg.LinAlgError:
            raise InputError("apply_measurement: H P Hᵀ + R is singular; give a positive definite R") from None
        dx = K @ z
        ikh = np.eye(n) - K @ H
        P[:] = ikh @ P @ ikh.T + K @ R @ K.T
        st = self._st
        st[POS] += dx[ERR_P]
        st[VEL] += dx[ERR_V]
        st[QUAT] = fast.exp_times_quat(*st[QUAT], *dx[ERR_TH])
        if n == 15:
            st[BIAS_ACC] += dx[ERR_BA]
            st[BIAS_GYRO] += dx[ERR_BG]
        if self.prm.smooth:
            j = int(self._seg[fast.SEG_RING] + self._seg[fast.SEG_LEN] - 1) % self._buf_post.shape[0]
            if self._buf_updates[j] == 0:  # P⁻ of the row is its P⁺ before this update (the smoother reads it)
                self._buf_pred[j] = self._buf_post[j][np.tril_indices(n)]
            self._buf_updates[j] = -1  # the smoother factorises P⁻ at this row
            self._buf_dx[j] += dx
            self._buf_post[j] = P
        r = self._out_filled - 1
        o = self._out
        o["pos_n"][r], o["vel_n"][r], o["q_nb"][r] = st[POS], st[VEL], st[QUAT]
        o["acc_bias_b"][r], o["gyro_bias_b"][r] = st[BIAS_ACC], st[BIAS_GYRO]
        o["pos_sigma_n"][r] = np.sqrt(np.maximum(np.diag(P)[ERR_P], 0.0))
        o["pos_cov_en"][r] = P[ERR_P.start, ERR_P.start + 1]
        self._n_external += 1

    # ------------------------------------------------------------------------------------------ smoothing
    def _hand_on(self, rows_out) -> None:
        """Give the closed segments to the smoothing thread (they correct ``rows_out`` in place; without one,
        smooth them here), then wait until the ring has room for the next segment (``fast.filter_chunk``
        docstring)."""
        seg, nc = self._seg, int(self._seg[fast.SEG_N_CLOSED])
        if self._workers is None:
            self._workers = _smoothing_workers()
        if nc and not self._workers:
            self._smooth_here(rows_out)
        elif nc:
            if self._pool is None:
                self._pool = ThreadPoolExecutor(max_workers=self._workers, thread_name_prefix="bootnav-smoother")
            batch = self._closed[:nc].copy()
            fut = self._pool.submit(fast.smooth_segments, batch, self.n, rows_out, self._bufs)
            self._in_flight.append((fut, int(batch[0, fast.CL_RING])))
            seg[fast.SEG_N_CLOSED] = 0
        cap = self._buf_post.shape[0]
        while self._in_flight and seg[fast.SEG_RING] + self.prm.max_segment - seg[fast.SEG_TAIL] > cap:
            self._counters[fast.SMOOTHER_SKIPPED] += self._in_flight.popleft()[0].result()
            seg[fast.SEG_TAIL] = self._in_flight[0][1] if self._in_flight else seg[fast.SEG_RING]
        if not self._in_flight:  # nothing listed or smoothing: the open segment is the oldest buffer user
            seg[fast.SEG_TAIL] = seg[fast.SEG_RING]

    def _smooth_here(self, rows_out) -> None:
        """Smooth the closed segments still listed, in this thread."""
        nc = int(self._seg[fast.SEG_N_CLOSED])
        if nc:
            self._counters[fast.SMOOTHER_SKIPPED] += fast.smooth_segments(self._closed[:nc], self.n, rows_out,
                                                                          self._bufs)
            self._seg[fast.SEG_N_CLOSED] = 0

    def _drain(self, rows_out) -> None:
        """Smooth every closed segment: those still listed here in this thread, while the smoothing thread
        finishes its batches; afterwards every row before the open segment is final."""
        seg = self._seg
        self._smooth_here(rows_out)
        try:
            while self._in_flight:
                self._counters[fast.SMOOTHER_SKIPPED] += self._in_flight.popleft()[0].result()
        finally:
            if self._pool is not None:
                self._pool.shutdown()  # waits for whatever an error left running
                self._pool = None
            self._workers = None
        seg[fast.SEG_TAIL] = seg[fast.SEG_RING]

    # -------------------------------------------------------------------------------------------- inside
    def _check(self, t_s, acc_b, gyro_b, stance):
        if self._finished:
            raise InputError("this StreamNavigator is finished; build a new one for another record")
        t_s = np.ascontiguousarray(t_s, dtype=np.float64).reshape(-1)
        m = t_s.shape[0]
        acc_b = np.ascontiguousarray(acc_b, dtype=np.float64).reshape(-1, 3) if m else np.zeros((0, 3))
        gyro_b = np.ascontiguousarray(gyro_b, dtype=np.float64).reshape(-1, 3) if m else np.zeros((0, 3))
        stance = np.asarray(stance, dtype=bool).reshape(-1)
        base = self._n_pushed
        if acc_b.shape != (m, 3) or gyro_b.shape != (m, 3) or stance.shape != (m,):
            raise InputError(f"push at sample {base}: expected t_s ({m},), acc_b and gyro_b ({m}, 3), stance ({m},); "
                             f"got {acc_b.shape}, {gyro_b.shape}, {stance.shape}")
        for name, a in (("t_s", t_s), ("acc_b", acc_b), ("gyro_b", gyro_b)):
            bad = ~np.isfinite(a) if a.ndim == 1 else ~np.isfinite(a).all(axis=1)
            if bad.any():
                i = int(np.argmax(bad))
                raise InputError(f"{name} has a non-finite value (NaN/inf) at sample {base + i}; remove or "
                                 "interpolate it before pushing")
        if m:
            prev = t_s[0] if self._t_pushed_last is None else self._t_pushed_last
            back = np.diff(t_s, prepend=prev) < 0
            if back.any():
                i = int(np.argmax(back))
                before = t_s[i - 1] if i else prev
                raise InputError(f"timestamps go backwards at sample {base + i}: {before!r} then {t_s[i]!r}")
            self._t_pushed_last = float(t_s[-1])
        return t_s, acc_b, gyro_b, stance

    def _push_checked(self, t_s, acc_b, gyro_b, stance, xvar) -> NavRows:
        """Queue checked samples (``xvar``: saturation variance × Δt₀, (m, 6) or None) and filter what is
        decided."""
        m = t_s.shape[0]
        if m:
            if self._n_pushed == 0:
                self._last_zupt_t = float(t_s[0])  # the paper mode's first open-loop interval starts here
            if self._q_t.shape[0]:
                self._q_t = np.concatenate([self._q_t, t_s])
                self._q_acc = np.concatenate([self._q_acc, acc_b])
                self._q_gyro = np.concatenate([self._q_gyro, gyro_b])
                self._q_stance = np.concatenate([self._q_stance, stance])
                self._q_xvar = np.concatenate([self._q_xvar, np.zeros((m, 6)) if xvar is None else xvar])
            else:
                self._q_t, self._q_acc, self._q_gyro, self._q_stance = t_s, acc_b, gyro_b, stance
                self._q_xvar = np.zeros((m, 6)) if xvar is None else np.ascontiguousarray(xvar, dtype=np.float64)
            if xvar is not None:
                self._n_inflated += int(np.count_nonzero((xvar > 0).any(axis=1)))
            self._n_pushed += m
        return self._advance(final=False)

    def _decide(self, final: bool) -> tuple[int, np.ndarray]:
        """ZUPT mask of the longest decided prefix of the queue: (its length, the mask)."""
        t, s = self._q_t, self._q_stance
        m = t.shape[0]
        z = s.copy()
        if not m or not self._onset or not s.any():
            return m, z
        delay, frac = self.settings.zupt_onset_delay_s, self.settings.zupt_onset_max_fraction
        starts, stops = runs(s)
        for a, b in zip(starts.tolist(), stops.tolist()):
            carried = a == 0 and self._prev_raw
            t0 = self._run_t0 if carried else float(t[a])
            if (self._run_initial if carried else self._n_done + a == 0):
                continue  # a phase starting at the first sample is kept whole
            x = frac * (t[b - 1] - t0)
            if not (b < m or final or x >= delay):
                # open phase, too short to know its cut yet: samples before t0 + x are cut in any case
                c = a + int(np.searchsorted(t[a:b], t0 + x, side="left"))
                z[a:c] = False
                return c, z[:c]
            cut_t = t0 + min(delay, x)
            z[a:a + int(np.searchsorted(t[a:b], cut_t, side="left"))] = False
        return m, z

    def _advance(self, final: bool) -> NavRows:
        """Filter the decided prefix of the queue; return the rows that became final."""
        L, zupt = self._decide(final)
        t = self._q_t[:L]
        n_open = self._out_filled - self._out_from
        if L == 0 and not (final and n_open):
            return NavRows.empty(self._out_start)
        if L:
            self._carry_onset_context(L, t)
        inp = self._kernel_inputs(L, t, zupt)
        out = self._output_rows(n_open, L, t, zupt)
        filled = n_open + L
        tc = time.perf_counter()
        self._filter(inp, L, n_open, out, final)
        if final:
            n_final = filled
        else:
            n_final = int(self._seg[fast.SEG_ROW]) if self.prm.smooth else filled - 1
        self.run_s += time.perf_counter() - tc
        if L:
            self._dequeue(L, t, zupt)
        rows = NavRows(self._out_start, out["t_s"][:n_final], out["pos_n"][:n_final], out["vel_n"][:n_final],
                       out["q_nb"][:n_final], out["acc_bias_b"][:n_final], out["gyro_bias_b"][:n_final],
                       out["pos_sigma_n"][:n_final], out["pos_cov_en"][:n_final], out["stance"][:n_final],
                       out["zupt"][:n_final])
        self._out, self._out_from, self._out_filled = out, n_final, filled
        self._out_start += n_final
        return rows

    def _carry_onset_context(self, L: int, t) -> None:
        """The onset delay's context for what stays queued after the first L samples (times ``t``): the raw
        stance of the last of them, and the start of its stance run (``_decide`` reads them)."""
        s = self._q_stance
        if s[L - 1]:
            false_before = np.flatnonzero(~s[:L])
            if false_before.size:
                a = int(false_before[-1]) + 1
                self._run_t0, self._run_initial = float(t[a]), self._n_done + a == 0
            elif not self._prev_raw:
                self._run_t0, self._run_initial = float(t[0]), self._n_done == 0
        self._prev_raw = bool(s[L - 1])

    def _step_times(self, L: int, t) -> np.ndarray:
        """Δt to each of the first L queued samples (times ``t``) with a look-back row 0; counts the repeated
        times, the gaps and the longest step for ``info``."""
        dt = np.empty(L + 1)
        dt[0] = 0.0
        if not L:
            return dt
        prev_t = t[0] if self._t_done_last is None else self._t_done_last
        dt[1] = t[0] - prev_t
        np.subtract(t[1:], t[:-1], out=dt[2:])
        step = dt[1:]
        self._n_duplicates += int((step == 0).sum()) - (1 if self._n_done == 0 else 0)
        gap = step > GAP_FACTOR * self.nominal_dt_s
        n_gap = int(gap.sum())
        if n_gap and len(self._gaps) < MAX_LISTED_GAPS:
            idx = np.flatnonzero(gap)[:MAX_LISTED_GAPS - len(self._gaps)]
            self._gaps += [(self._n_done + int(i), float(step[i])) for i in idx]
        self._n_gaps += n_gap
        self._max_dt = max(self._max_dt, float(step.max()))
        return dt

    def _kernel_inputs(self, L: int, t, zupt) -> fast.KernelInputs:
        """The kernel's input rows of the first L queued samples (times ``t``, ZUPT mask ``zupt``), with one
        look-back row (row 0: only its ZUPT flag is read)."""
        dt = self._step_times(L, t)
        if L:
            self._n_onset_skipped += int(np.count_nonzero(self._q_stance[:L])) - int(np.count_nonzero(zupt))
        acc = np.empty((L + 1, 3))
        acc[0] = 0.0
        acc[1:] = self._q_acc[:L]
        gyr = np.empty((L + 1, 3))
        gyr[0] = 0.0
        gyr[1:] = self._q_gyro[:L]
        zm = np.empty(L + 1, dtype=np.bool_)
        zm[0] = self._prev_zupt
        zm[1:] = zupt
        if self._increments and L:  # two-sample sculling and coning (increments.py), the previous sample carried
            prev = self._prev_sample
            a_prev = previous_rows(acc[1:], None if prev is None else prev[0])
            g_prev = previous_rows(gyr[1:], None if prev is None else prev[1])
            d_prev = previous_rows(dt[1:], None if prev is None else prev[2])
            self._prev_sample = (acc[L].copy(), gyr[L].copy(), float(dt[L]))
            acc[1:], gyr[1:] = sculling_coning(acc[1:], gyr[1:], dt[1:], a_prev, g_prev, d_prev)
        xvar = np.empty((L + 1, 6))
        xvar[0] = 0.0
        xvar[1:] = self._q_xvar[:L]
        return fast.KernelInputs(dt, acc, gyr, zm, xvar, self._open_loop_intervals(L, t, zupt, zm))

    def _open_loop_intervals(self, L: int, t, zupt, zm) -> np.ndarray:
        """Paper mode: at each input row where a ZUPT run starts, the open-loop interval it closes, the time since
        the last ZUPT sample before it (riccati.py); zeros otherwise."""
        tau = np.zeros(L + 1)
        if self.prm.riccati and L:
            on = np.flatnonzero(zm[1:] & ~zm[:-1])
            true_idx = np.flatnonzero(zupt)
            k = np.searchsorted(true_idx, on) - 1
            last = np.where(k >= 0, t[true_idx[np.maximum(k, 0)]], self._last_zupt_t) if on.size else on
            tau[1 + on] = t[on] - last
            if true_idx.size:
                self._last_zupt_t = float(t[true_idx[-1]])
        return tau

    def _output_rows(self, n_open: int, L: int, t, zupt) -> dict:
        """Output rows: the n_open not-final ones carried over, then room for the L new ones."""
        out = {name: np.empty((n_open + L, 3)) for name in _ROWS3}
        out["q_nb"] = np.empty((n_open + L, 4))
        out["t_s"] = np.empty(n_open + L)
        out["pos_cov_en"] = np.empty(n_open + L)
        out["stance"] = np.empty(n_open + L, dtype=bool)
        out["zupt"] = np.empty(n_open + L, dtype=bool)
        if n_open:
            for name, arr in out.items():
                arr[:n_open] = self._out[name][self._out_from:self._out_filled]
        out["t_s"][n_open:] = t
        out["stance"][n_open:] = self._q_stance[:L]
        out["zupt"][n_open:] = zupt
        return out

    def _gate_pieces(self, L: int) -> list:
        """(first input row, stop, heading gate flag or None: as set) of the runs of one gate flag each (input
        row k = queued sample k - 1)."""
        if self._q_gate is None or not L:
            return [(1, L + 1, None)]
        g = np.where(np.isnan(self._q_gate[:L]), self._gate_set, self._q_gate[:L])
        cut = np.flatnonzero(np.diff(g)) + 1
        edges = np.concatenate(([0], cut, [L]))
        return [(int(a) + 1, int(b) + 1, float(g[a])) for a, b in zip(edges[:-1], edges[1:])]

    def _filter(self, inp: fast.KernelInputs, L: int, n_open: int, out: dict, final: bool) -> None:
        """Run the kernel over the L input rows into ``out`` (after its n_open carried rows), smoothing the
        segments it closes; ``final``: close the last one too."""
        self._seg[fast.SEG_ROW] -= self._out_from
        rows_out = fast.PathRows(out["pos_n"], out["vel_n"], out["q_nb"], out["acc_bias_b"], out["gyro_bias_b"])
        unc = fast.PathUncertainty(out["pos_sigma_n"], out["pos_cov_en"])
        filled = n_open + L
        if self._workers is None and self.prm.smooth:
            self._workers = _smoothing_workers()
        book = self._book if self._workers else self._book_inline
        try:
            for k, stop, flag in self._gate_pieces(L):
                if flag is not None:
                    self._st[HDE_GATE] = flag
                while k < stop:
                    k = fast.filter_chunk(k, stop, inp, n_open - 1, self.kernel_model, self._state, rows_out, unc,
                                          self._bufs, book, self._counts)
                    if k < stop:  # closed segments due: smooth them in another thread while the filter goes on
                        self._hand_on(rows_out)
            if final and self.prm.smooth and filled:
                fast.close_segment(self._seg, self._closed, self._counters, filled)
        finally:
            if self.prm.smooth:
                self._drain(rows_out)

    def _dequeue(self, L: int, t, zupt) -> None:
        """Drop the first L queued samples, filtered (times ``t``, ZUPT mask ``zupt``)."""
        self._t_done_last = float(t[-1])
        self._prev_zupt = bool(zupt[-1])
        self._n_done += L
        self._q_t, self._q_acc, self._q_gyro = self._q_t[L:], self._q_acc[L:], self._q_gyro[L:]
        self._q_stance, self._q_xvar = self._q_stance[L:], self._q_xvar[L:]
        if self._q_gate is not None:
            self._q_gate = self._q_gate[L:]

def run_fast(t_s, acc_b, gyro_b, stance, setup: FilterSetup, settings, tb, progress=None, extra_var=None,
             heading_gate=None):
    """Push a whole record through a ``StreamNavigator`` in a few chunks (arguments as
    ``filter.run_filter`` prepares them: ``setup`` = ``prepare.prepare_filter``'s, passed whole; ``stance`` is
    the ZUPT mask, ``extra_var`` the saturation variance, ``heading_gate`` the heading aid's per-sample gate
    or None; the chunks are cut where the gate changes, ``prepare.gated_chunks``).

    Returns
    -------
    (arrays dict pos_n, vel_n, q_nb, acc_bias_b, gyro_bias_b, pos_sigma_n, pos_cov_en; info dict)
    """
    N = t_s.shape[0]
    nav = StreamNavigator(settings, setup, tb.nominal_dt_s, apply_onset_delay=False)
    out = {name: np.empty((N, 3)) for name in ("pos_n", "vel_n", "acc_bias_b", "gyro_bias_b", "pos_sigma_n")}
    out["q_nb"] = np.empty((N, 4))
    out["pos_cov_en"] = np.empty(N)
    stance = np.ascontiguousarray(stance, dtype=np.bool_)
    xvar = None if extra_var is None else np.ascontiguousarray(extra_var, dtype=np.float64) * tb.nominal_dt_s
    # a few pushes for the progress callback, each at most _PUSH_MAX samples (bounded temporaries)
    n_chunks = max(1 if progress is None else min(10, N // 100_000), -(-N // _PUSH_MAX), 1)
    bounds = np.linspace(0, N, n_chunks + 1).astype(np.int64)

    def keep(rows):
        sl = slice(rows.start, rows.start + len(rows))
        for name, arr in out.items():
            arr[sl] = getattr(rows, name)

    t0 = time.perf_counter()
    for a, b, gate_open in gated_chunks(bounds, heading_gate):
        if heading_gate is not None:
            nav.set_heading_gate(gate_open)
        keep(nav._push_checked(t_s[a:b], acc_b[a:b], gyro_b[a:b], stance[a:b], None if xvar is None else xvar[a:b]))
        if progress is not None and b in bounds:
            progress(float(b) / N)
    keep(nav.finish())
    info = dict(nav.info, run_s=time.perf_counter() - t0, applied=nav._applied, final_P=nav.covariance)
    return out, info
