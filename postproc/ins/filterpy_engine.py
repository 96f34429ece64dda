"""Reference engine (``FilterSettings.engine = "reference"``): the ZUPT error-state filter as a textbook
per-sample loop on filterpy's ``KalmanFilter``. (A reference *path* for the accuracy metrics is another idea:
``postproc.reference_path``.)

Transparent on purpose (slow: a Python loop): every step reads like the equations in ``filter.py``'s
docstring, so the fast numba engine can be checked against it (tests/test_ins_engines.py: same trajectory to
1e-9 m). The error state lives in ``kf.x`` (zero after every reset), the covariance in ``kf.P``;
``kf.predict()`` does P ← F P Fᵀ + Q and ``kf.update()`` does the Joseph-form update.

``ReferenceNavigator`` is the loop with its state kept between pushes and an outside update at the last sample
(``apply_measurement``); ``run_reference`` pushes a whole record through it, the two-boot fusion drives two in
lockstep (tests/test_twoboots_engines.py: the fused feet of both engines agree to 1e-6 m).
``RecordReference`` puts the engine behind the stream's push/finish for the block passes of ``process``
(``filter.navigator``).
"""

from __future__ import annotations

import time

import numpy as np
from filterpy.kalman import KalmanFilter

from bootnav.errors import InputError
from bootnav.postproc.ins.layout import (BIAS_ACC, BIAS_GYRO, ERR_BA, ERR_BG, ERR_P, ERR_TH, ERR_V, HDE_GATE, POS,
                                         QUAT, VEL, initial_nominal_state)
from bootnav.postproc.ins.measurements import HEADING_AID, LEVEL_HEIGHT, N_KINDS, ZUPT, ZuptMeasurement, active_measurements
from bootnav.postproc.ins.increments import previous_rows, sculling_coning
from bootnav.postproc.ins.mechanization import strapdown_step
from bootnav.postproc.ins.prepare import (MAX_LISTED_GAPS, FilterSetup, delay_zupt_onsets, gated_chunks, prepare_filter,
                                          saturation_variance)
from bootnav.postproc.ins.quaternion import correct_attitude, quat_to_rotmat
from bootnav.postproc.ins.smoother import apply_smoothed_correction, error_dynamics, rts_backward_numpy
from bootnav.postproc.ins.stream import NavRows

_ROWS = ("t_s", "pos_n", "vel_n", "q_nb", "acc_bias_b", "gyro_bias_b", "pos_sigma_n", "pos_cov_en", "zupt")  # NavRows' order


def process_noise(prm, dt: float, dt_nom: float, n: int, f_b=None, omega_b=None, extra=None,
                  c_nb=None) -> np.ndarray:
    """Q_d for a step of length dt (settings.py: per-sample sigmas at the nominal period, bias random walks).

    With ``acc_scale_noise`` / ``gyro_scale_noise`` κ the per-sample variance is σ² + κ² |signal|²
    (f_b, omega_b: the bias-corrected sample of this step). ``extra`` (6,) = per-sample variance of the
    body axes ax..gz of a saturated sample (filter.saturation_variance), acting along those body axes:
    Q_v += C diag(extra_acc) Cᵀ Δt₀ Δt, Q_θ += C diag(extra_gyro) Cᵀ Δt₀ Δt (c_nb: attitude of the step).
    ``prm``: ``params.KernelParams``.
    """
    var_a = prm.var_acc
    var_g = prm.var_gyro
    if f_b is not None:
        var_a += prm.var_acc_scale * float(f_b @ f_b)
    if omega_b is not None:
        var_g += prm.var_gyro_scale * float(omega_b @ omega_b)
    var = np.zeros(n)  # position: no noise of its own
    var[ERR_V] = var_a * dt
    var[ERR_TH] = var_g * dt
    if n == 15:
        var[ERR_BA] = prm.var_acc_bias_rw * dt
        var[ERR_BG] = prm.var_gyro_bias_rw * dt
    q = np.diag(var)
    if extra is not None:
        q[ERR_V, ERR_V] += c_nb @ np.diag(extra[:3]) @ c_nb.T * dt_nom * dt
        q[ERR_TH, ERR_TH] += c_nb @ np.diag(extra[3:6]) @ c_nb.T * dt_nom * dt
    return q


class ReferenceNavigator:
    """The reference filter pushed in chunks, with an outside measurement at the last sample.

    The same per-sample loop as a whole-record run (``run_reference`` pushes the record through it), with the
    part of ``stream.StreamNavigator``'s interface the two-boot fusion drives: ``push`` (the ZUPT mask, onset
    delay applied by the caller), ``last_index``, ``position_n``, ``position_cov_n``, ``apply_measurement``,
    ``finish``, ``info``. A smoother segment is closed when the next sample shows that it ended (after the
    last sample of a stance phase, or at ``prm.max_segment`` samples), as in the fast engine, so an outside
    update of the last sample always lands in the open segment. Every output row is kept until ``finish``
    (a reference, not memory-bounded): ``push`` returns no rows, ``finish`` all of them.

    Parameters
    ----------
    settings : FilterSettings
        Validated filter settings.
    setup : prepare.FilterSetup
        Initial state and covariance, paper-mode gain (with its per-sample open-loop times τ of the whole
        record), kernel parameters.
    nominal_dt_s : float
        Nominal sample period Δt₀, s.
    """

    def __init__(self, settings, setup, nominal_dt_s: float):
        self.settings = settings
        self.prm = prm = setup.prm
        self.n = n = settings.n_states
        self.nominal_dt_s = float(nominal_dt_s)
        self.zupt_gain = setup.zupt_gain
        self.kf = KalmanFilter(dim_x=n, dim_z=3)
        self.kf.P = np.array(setup.P0, dtype=float, copy=True)
        self.measurements = active_measurements(settings, prm)
        self._zupt = ZuptMeasurement(prm, n)  # paper mode: its z, with the constant Riccati gain
        self._H_zupt = np.zeros((3, n))
        self._H_zupt[:, ERR_V] = np.eye(3)
        self._R_zupt = np.eye(3) * prm.var_zupt
        self.st = initial_nominal_state(setup.q0_nb, setup.acc_bias0_b, setup.gyro_bias0_b,
                                        settings.heading_aid_reference_rad)
        self._out = {k: np.empty((0, 4 if k == "q_nb" else 3)) for k in _ROWS[1:-1]}
        self._out["t_s"] = np.empty(0)
        self._out["pos_cov_en"] = np.empty(0)
        self._out["zupt"] = np.empty(0, dtype=bool)
        self._k = 0  # samples filtered
        self._t_last = None
        self._prev_zupt = False
        self._increments = settings.strapdown == "increments"  # sculling and coning (increments.py)
        self._prev_sample = None
        self._seg = []  # per sample of the open segment: [P_pred, P_post, fpar, dx]
        self._seg_start = 0
        self.applied = np.zeros(N_KINDS, dtype=np.int64)
        self.segments = 0
        self.n_external = 0
        self.run_s = 0.0
        self._finished = False

    @property
    def last_index(self) -> int:
        """Index of the last filtered sample (−1 before the first)."""
        return self._k - 1

    @property
    def position_n(self) -> np.ndarray:
        """(3,) position at the last filtered sample, m (filtered, not smoothed)."""
        return self.st[POS].copy()

    @property
    def position_cov_n(self) -> np.ndarray:
        """(3, 3) covariance of the position error at the last filtered sample, m²."""
        return np.array(self.kf.P[ERR_P, ERR_P], dtype=float)

    @property
    def covariance(self) -> np.ndarray:
        """(n, n) error-state covariance at the last filtered sample."""
        return np.array(self.kf.P, dtype=float)

    @property
    def info(self) -> dict:
        """Counters of the run so far (JSON-serialisable)."""
        return {"engine": "reference", "n_filtered": self._k, "n_updates": int(self.applied[ZUPT]),
                "heading_aid_updates": int(self.applied[HEADING_AID]),
                "level_height_updates": int(self.applied[LEVEL_HEIGHT]), "external_updates": self.n_external,
                "smoother_segments": self.segments, "run_s": self.run_s}

    def push(self, t_s, acc_b, gyro_b, zupt, saturated=None) -> NavRows:
        """Filter these samples (``zupt``: the ZUPT mask; ``saturated``: as ``prepare.saturation_variance``
        accepts); returns no rows (``finish`` returns them all)."""
        t_s = np.asarray(t_s, dtype=float).reshape(-1)
        m = t_s.shape[0]
        self._push(t_s, np.asarray(acc_b, dtype=float).reshape(m, 3), np.asarray(gyro_b, dtype=float).reshape(m, 3),
                   np.asarray(zupt, dtype=bool).reshape(m), saturation_variance(saturated, m, self.settings))
        return self._rows(0)

    def _push(self, t, acc, gyr, zupt, extra_var) -> None:
        """The loop over the samples (``extra_var``: (m, 6) saturation variance per sample, or None)."""
        if self._finished:
            raise InputError("this ReferenceNavigator is finished; build a new one for another record")
        m = t.shape[0]
        if m == 0:
            return
        t0 = time.perf_counter()
        # the samples with one look-back row (the measurement models read stance[k − 1])
        a = np.zeros((m + 1, 3))
        a[1:] = acc
        g = np.zeros((m + 1, 3))
        g[1:] = gyr
        if self._increments:
            dt = np.diff(t, prepend=t[0] if self._t_last is None else self._t_last)
            prev = self._prev_sample
            rows = [previous_rows(x, None if prev is None else p) for x, p in zip((acc, gyr, dt), prev or (None,) * 3)]
            self._prev_sample = (acc[-1].copy(), gyr[-1].copy(), float(dt[-1]))
            a[1:], g[1:] = sculling_coning(acc, gyr, dt, *rows)
        z = np.empty(m + 1, dtype=bool)
        z[0] = self._prev_zupt
        z[1:] = zupt
        k0 = self._k
        if k0 + m > self._out["t_s"].shape[0]:  # room for the new rows, capacity doubled (amortised O(1) a row)
            cap = max(k0 + m, 2 * self._out["t_s"].shape[0])
            for name, arr in self._out.items():
                grown = np.zeros((cap,) + arr.shape[1:], dtype=arr.dtype)
                grown[:k0] = arr[:k0]
                self._out[name] = grown
        self._out["t_s"][k0:k0 + m] = t
        self._out["zupt"][k0:k0 + m] = zupt
        for i in range(1, m + 1):
            if self.prm.smooth and self._seg and (len(self._seg) >= self.prm.max_segment or (z[i - 1] and not z[i])):
                self._close_segment()
            dt = t[i - 1] - self._t_last if self._t_last is not None else 0.0
            self._t_last = t[i - 1]
            self._step(dt, a, g, z, i, None if extra_var is None else extra_var[i - 1])
        self._prev_zupt = bool(zupt[-1])
        self.run_s += time.perf_counter() - t0

    def _step(self, dt, acc_b, gyro_b, zupt, i, extra) -> None:
        """Sample ``self._k`` = local row ``i``: time update, measurement updates, reset, smoother buffer."""
        st, kf, prm, n, k = self.st, self.kf, self.prm, self.n, self._k
        # --- time update: eq. 1 and P ← F P Fᵀ + Q
        f_b, omega_b = acc_b[i] - st[BIAS_ACC], gyro_b[i] - st[BIAS_GYRO]
        st[POS], st[VEL], st[QUAT], f_n, c_nb = strapdown_step(st[POS], st[VEL], st[QUAT], f_b, omega_b, dt,
                                                               prm.gravity, prm.midpoint)
        if dt > 0:
            kf.F = np.eye(n) + error_dynamics(f_n, c_nb, n) * dt
            kf.Q = process_noise(prm, dt, self.nominal_dt_s, n, f_b, omega_b, extra, c_nb)
            kf.predict()
        p_pred = kf.P.copy()
        # --- measurement updates (measurements.py), sequential: filterpy's innovation is z − H kf.x
        updated = False
        if self.zupt_gain is None:
            for meas in self.measurements:
                zhr = meas.evaluate(st, np.asarray(kf.x, dtype=float).reshape(-1), acc_b, gyro_b, zupt, i)
                if zhr is not None:
                    z, h, r = zhr
                    kf.update(z.reshape(-1, 1), R=r, H=h)  # filterpy wants a column when H is passed
                    self.applied[meas.kind] += 1
                    updated = True
        elif zupt[i] and dt > 0:
            # paper mode: constant Riccati gain on the ZUPT's z = −v̂, Joseph form with that gain
            z, _, _ = self._zupt.evaluate(st, np.zeros(n), acc_b, gyro_b, zupt, i)
            gain = self.zupt_gain.discrete(dt, self.zupt_gain.tau[k], c_nb, n)
            kf.x = gain @ z.reshape(3, 1)
            ikh = np.eye(n) - gain @ self._H_zupt
            kf.P = ikh @ kf.P @ ikh.T + gain @ self._R_zupt @ gain.T
            self.applied[self._zupt.kind] += 1
            updated = True
        dx = np.asarray(kf.x, dtype=float).reshape(-1).copy()
        if updated:
            self._reset(dx)
        self._store_row(k)
        if prm.smooth:
            self._seg.append([p_pred, kf.P.copy(), np.concatenate([[dt], f_n, c_nb.ravel()]), dx])
        self._k += 1

    def _reset(self, dx) -> None:
        """Apply δx to the nominal state, δx ← 0."""
        st = self.st
        st[POS] += dx[ERR_P]
        st[VEL] += dx[ERR_V]
        st[QUAT] = correct_attitude(st[QUAT], dx[ERR_TH])
        if self.n == 15:
            st[BIAS_ACC] += dx[ERR_BA]
            st[BIAS_GYRO] += dx[ERR_BG]
        self.kf.x = np.zeros((self.n, 1))

    def _store_row(self, k: int) -> None:
        st, o = self.st, self._out
        o["pos_n"][k], o["vel_n"][k], o["q_nb"][k] = st[POS], st[VEL], st[QUAT]
        o["acc_bias_b"][k], o["gyro_bias_b"][k] = st[BIAS_ACC], st[BIAS_GYRO]
        o["pos_sigma_n"][k] = np.sqrt(np.maximum(np.diag(self.kf.P)[ERR_P], 0.0))
        o["pos_cov_en"][k] = self.kf.P[ERR_P.start, ERR_P.start + 1]

    def _close_segment(self) -> None:
        _smooth_segment(self._seg, self._seg_start, self.n, self._out)
        self.segments += 1
        self._seg_start += len(self._seg)
        self._seg = []

    def apply_measurement(self, z, H, R) -> None:
        """Kalman update (filterpy, Joseph form) of the error state at the last filtered sample with
        z = H δx + ν, ν ~ N(0, R) (as ``stream.StreamNavigator.apply_measurement``): δx is injected into the
        nominal state and added to that sample's smoother correction, whose posterior covariance it replaces.

        Parameters
        ----------
        z : (m,) array
        H : (m, n) array
        R : (m, m) array
        """
        if self._finished or self._k == 0:
            raise InputError("apply_measurement needs a filtered sample and an unfinished navigator "
                             f"({self._k} filtered, finished={self._finished})")
        z = np.atleast_1d(np.asarray(z, dtype=float))
        H = np.atleast_2d(np.asarray(H, dtype=float))
        R = np.atleast_2d(np.asarray(R, dtype=float))
        if z.ndim != 1 or H.shape != (z.shape[0], self.n) or R.shape != (z.shape[0],) * 2:
            raise InputError(f"apply_measurement: expected z (m,), H (m, {self.n}), R (m, m); got {z.shape}, "
                             f"{H.shape}, {R.shape}")
        self.kf.update(z.reshape(-1, 1), R=R, H=H)
        dx = np.asarray(self.kf.x, dtype=float).reshape(-1).copy()
        self._reset(dx)
        if self.prm.smooth:
            self._seg[-1][1] = self.kf.P.copy()
            self._seg[-1][3] = self._seg[-1][3] + dx
        self._store_row(self._k - 1)
        self.n_external += 1

    def finish(self) -> NavRows:
        """Close the last smoother segment; every row of the record (start 0)."""
        if self._finished:
            raise InputError("this ReferenceNavigator is finished; build a new one for another record")
        if self.prm.smooth and self._seg:
            self._close_segment()
        self._finished = True
        return self._rows(self._k)

    def _rows(self, m: int) -> NavRows:
        """The first ``m`` rows (the pushed mask is the ZUPT mask: ``stance`` = ``zupt``)."""
        o = {name: self._out[name][:m] for name in _ROWS}
        return NavRows(0, *(o[name] for name in _ROWS[:-1]), o["zupt"].copy(), o["zupt"])


def run_reference(t_s, acc_b, gyro_b, stance, setup: FilterSetup, settings, tb, progress=None, extra_var=None,
                  heading_gate=None):
    """The filter as a per-sample loop (arguments and results as ``stream.run_fast``): the whole record
    pushed through a ``ReferenceNavigator`` in up to 10 chunks (one per progress report), cut where the
    heading gate changes."""
    N = t_s.shape[0]
    nav = ReferenceNavigator(settings, setup, tb.nominal_dt_s)
    stance = np.asarray(stance, dtype=bool)
    bounds = np.linspace(0, N, (10 if progress is not None and N >= 10 else 1) + 1).astype(np.int64)
    t0 = time.perf_counter()
    for a, b, gate_open in gated_chunks(bounds, heading_gate):
        nav.st[HDE_GATE] = 1.0 if gate_open else 0.0
        nav._push(t_s[a:b], acc_b[a:b], gyro_b[a:b], stance[a:b], None if extra_var is None else extra_var[a:b])
        if progress is not None and b in bounds:
            progress(b / N)
    rows = nav.finish()
    out = {k: getattr(rows, k) for k in _ROWS[1:-1]}
    info = {"run_s": time.perf_counter() - t0, "applied": nav.applied, "smoother_segments": nav.segments,
            "final_P": nav.covariance}
    return out, info


def _smooth_segment(seg, start, n, out):
    m = len(seg)
    if m < 2:
        return
    p_pred = np.array([s[0] for s in seg])
    p_post = np.array([s[1] for s in seg])
    fpar = np.array([s[2] for s in seg])
    dx_upd = np.array([s[3] for s in seg])
    dxs = rts_backward_numpy(p_post, p_pred, fpar, dx_upd, m, n)
    for j in range(m - 1):
        k = start + j
        apply_smoothed_correction(out["pos_n"][k], out["vel_n"][k], out["q_nb"][k], out["acc_bias_b"][k],
                                  out["gyro_bias_b"][k], dxs[j])


class RecordReference:
    """The reference engine behind the part of ``stream.StreamNavigator``'s interface the block passes use
    (``passes.BlockPasses``: ``push(t_s, acc_b, gyro_b, stance, saturated, heading_gate=…)`` → ``NavRows``,
    ``finish``, ``info``, ``covariance``, ``set_heading_gate``); built by ``filter.navigator`` for
    ``FilterSettings.engine = "reference"``.

    It keeps every pushed sample and runs the whole record at ``finish``, as ``filter.run_filter`` does: the
    onset delay on the whole stance mask (``prepare.delay_zupt_onsets``), the paper mode's gain with the
    per-sample open-loop times τ of the whole record (``prepare.prepare_filter(t_s, zupt_mask)``), then the
    per-sample loop (``ReferenceNavigator``) in chunks cut where the heading gate changes. ``push`` returns no
    rows, ``finish`` every row (start 0; ``stance`` the pushed mask, ``zupt`` the delayed one). Not
    memory-bounded and slow (a Python loop, ~0.12 ms per sample: ``FilterSettings.engine``): a reference. No
    outside updates (``apply_measurement``): the two-boot fusion drives ``ReferenceNavigator`` itself.

    Parameters
    ----------
    init : object
        Initial state (``StreamNavigator.from_initial_state``'s).
    gravity : float
        Local gravity magnitude, m/s².
    nominal_dt_s : float
        Nominal sample period Δt₀, s.
    settings : FilterSettings
        Validated filter settings with ``engine = "reference"``.
    """

    def __init__(self, init, gravity: float, nominal_dt_s: float, settings):
        self.settings = settings
        self.init = init
        self.gravity = float(gravity)
        self.nominal_dt_s = float(nominal_dt_s)
        self._P0 = prepare_filter(init, gravity, settings, nominal_dt_s).P0  # refuses a bad init / gravity now
        self._parts: list[tuple] = []  # (t, acc, gyro, stance, extra variance or None, gate) of each push
        self._gate_set = True
        self._n_pushed = 0
        self._nav: ReferenceNavigator | None = None
        self._info: dict = {}
        self._finished = False

    @property
    def n_pushed(self) -> int:
        """Samples pushed so far."""
        return self._n_pushed

    @property
    def covariance(self) -> np.ndarray:
        """(n, n) error-state covariance at the last filtered sample (P₀ before ``finish``: nothing is
        filtered until then)."""
        return self._nav.covariance if self._nav is not None else self._P0.copy()

    @property
    def info(self) -> dict:
        """Counters of the run, with ``stream.StreamNavigator.info``'s keys (zero before ``finish``)."""
        return dict(self._info) if self._info else {"n_pushed": self._n_pushed, "n_filtered": 0}

    def set_heading_gate(self, open_: bool) -> None:
        """The heading aid's gate for the samples pushed from now on without their own ``heading_gate``."""
        self._gate_set = bool(open_)

    def push(self, t_s, acc_b, gyro_b, stance, saturated=None, heading_gate=None) -> NavRows:
        """Keep these samples (arguments as ``StreamNavigator.push``); no rows until ``finish``."""
        if self._finished:
            raise InputError("this reference navigator is finished; build a new one for another record")
        t_s = np.array(t_s, dtype=float).reshape(-1)
        m = t_s.shape[0]
        acc_b = np.array(acc_b, dtype=float).reshape(m, 3)
        gyro_b = np.array(gyro_b, dtype=float).reshape(m, 3)
        stance = np.array(stance, dtype=bool).reshape(m)
        extra = saturation_variance(saturated, m, self.settings)
        if heading_gate is None:
            gate = np.full(m, self._gate_set)
        else:
            gate = np.array(heading_gate, dtype=bool).reshape(-1)
            if gate.shape != (m,):
                raise InputError(f"push at sample {self._n_pushed}: heading_gate has {gate.shape[0]} flags for {m} "
                                 "samples: give one per sample")
        if m:
            self._parts.append((t_s, acc_b, gyro_b, stance, extra, gate))
            self._n_pushed += m
        return NavRows.empty(0)

    def finish(self) -> NavRows:
        """Run the whole record (class docstring); every row, start 0."""
        from bootnav.core.timebase import gap_mask

        if self._finished:
            raise InputError("this reference navigator is finished; build a new one for another record")
        self._finished = True
        if not self._parts:
            return NavRows.empty(0)
        t, acc, gyr, stance, gate = (np.concatenate([p[i] for p in self._parts]) for i in (0, 1, 2, 3, 5))
        n = t.shape[0]
        extra = None
        if any(p[4] is not None for p in self._parts):
            extra = np.concatenate([np.zeros((len(p[0]), 6)) if p[4] is None else p[4] for p in self._parts])
        self._parts = []
        s = self.settings
        zupt = delay_zupt_onsets(t, stance, s.zupt_onset_delay_s, s.zupt_onset_max_fraction)
        setup = prepare_filter(self.init, self.gravity, s, self.nominal_dt_s, t, zupt)
        self._nav = nav = ReferenceNavigator(s, setup, self.nominal_dt_s)
        for a, b, gate_open in gated_chunks(np.array([0, n]), gate):
            nav.st[HDE_GATE] = 1.0 if gate_open else 0.0
            nav._push(t[a:b], acc[a:b], gyr[a:b], zupt[a:b], None if extra is None else extra[a:b])
        rows = nav.finish()
        rows.stance = stance
        step = np.diff(t, prepend=t[0])
        gaps = np.flatnonzero(gap_mask(step, self.nominal_dt_s))
        self._info = {
            "n_pushed": n, "n_filtered": n, "n_updates": int(nav.applied[ZUPT]),
            "heading_aid_updates": int(nav.applied[HEADING_AID]),
            "level_height_updates": int(nav.applied[LEVEL_HEIGHT]), "external_updates": 0,
            "smoother_segments": nav.segments, "smoother_skipped_steps": 0,
            "smoother_max_segment_samples": setup.prm.max_segment, "n_duplicates": int(np.count_nonzero(step == 0)) - 1,
            "n_gaps": int(gaps.size), "gaps": [(int(i), float(step[i])) for i in gaps[:MAX_LISTED_GAPS]],
            "max_dt_s": float(step.max()), "zupt_onset_samples_skipped": int(stance.sum() - zupt.sum()),
            "saturated_samples_inflated": 0 if extra is None else int((extra > 0).any(axis=1).sum()),
            "compile_s": 0.0, "run_s": nav.run_s}
        return rows

