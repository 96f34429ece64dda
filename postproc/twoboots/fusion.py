"""The two feet's navigators in lockstep on one clock, with the maximum-separation constraint [Skog2012].

Each foot runs its own navigator (the ZUPT filter + segment RTS smoother of ``FilterSettings.engine``) on its own
samples, stance mask (the single-foot run's, ZUPT onset delay applied beforehand, so every pushed sample is
filtered at once) and initial state; the right foot's initial yaw is uncertain by the frame alignment's σ
(``TwoBootSettings.heading_alignment_sigma_rad``), so the constraint can correct it. The session clock is
cut at the constraint instants; before each instant both navigators are pushed up to it, so both positions
belong to (within one sample period of) the same moment. There ``constraint.project_max_separation`` checks
‖p_L − p_R‖ ≤ γ and, when violated, injects the covariance-weighted projection into each foot as a scalar position pseudo-measurement
(``apply_measurement``): the update reaches heading, velocity and biases through the covariance, and the
smoother spreads it back over the segment before it. With ``constraint_gate_sigma`` > 0 a violation far
outside the two covariances is applied only as far as it is consistent with them
(``constraint.separation_variance_m2``; off by default, docs/twoboots.md).

Instants (``TwoBootSettings.instants``): the middle of every stance phase of either foot (default: the
resting foot's position is best known there, and the swinging foot is somewhere in its stride, where the
bound is most likely to bite), or every ``stance_check_interval_s`` within every stance phase.

With γ = ∞ no update is ever applied and each foot's path is its single-foot path to 1e-9 m (same engine,
same inputs, the right frame left unturned; tests/test_twoboots_fusion.py). ``FilterSettings.engine`` picks
the navigators: ``StreamNavigator`` (fast, numba) or ``filterpy_engine.ReferenceNavigator`` (the filterpy loop); both
take the same constraint measurement (``constraint.position_measurement``) through ``apply_measurement``, and
agree to floating-point accuracy (tests/test_twoboots_engines.py).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from bootnav.core.runs import runs
from bootnav.core.timebase import time_base
from bootnav.errors import InputError

from .constraint import position_measurement, project_max_separation, separation_variance_m2
from .settings import TwoBootSettings


@dataclass
class FootInput:
    """One foot's samples on the session clock and what its filter starts from (SI units)."""

    label: str
    t_s: np.ndarray  # (N,) s, session clock
    acc_b: np.ndarray  # (N, 3) m/s², the specific force the single-foot run used
    gyro_b: np.ndarray  # (N, 3) rad/s
    stance: np.ndarray  # (N,) bool, the single-foot run's stance mask
    init: Any  # calibration.InitialState (q_nb in the common frame)
    gravity: float
    saturated: np.ndarray | None = None  # saturation bits as the single-foot run used
    start_n: np.ndarray = field(default_factory=lambda: np.zeros(3))  # (3,) m, start position in the common frame
    init_yaw_sigma_rad: float | None = None  # initial yaw 1-σ in the common frame (None: the filter setting's)


@dataclass
class FusedFoot:
    """One foot's fused solution (the ``NavRows`` of its navigator, whole record)."""

    label: str
    t_s: np.ndarray
    pos_n: np.ndarray
    vel_n: np.ndarray
    q_nb: np.ndarray
    acc_bias_b: np.ndarray
    gyro_bias_b: np.ndarray
    pos_sigma_n: np.ndarray
    stance: np.ndarray
    info: dict = field(default_factory=dict)
    pos_cov_en: np.ndarray | None = None  # (N,) the foot filter's east-north position covariance P_EN, m² (ellipses)


@dataclass
class FusionOutput:
    left: FusedFoot
    right: FusedFoot
    n_checks: int  # constraint instants where both feet had a filtered sample
    n_active: int  # of those, where the bound was violated and both feet were updated
    max_separation_before_m: float  # largest ‖p̂_L − p̂_R‖ seen at a check (before its projection)
    seconds: float
    n_gated: int = 0  # of the active ones, where the excess was outside the consistency gate (R raised)


def constraint_instants(t_l: np.ndarray, zupt_l: np.ndarray, t_r: np.ndarray, zupt_r: np.ndarray,
                        settings: TwoBootSettings) -> np.ndarray:
    """Sorted session times at which the bound is checked (module docstring), within both records."""
    times = []
    for t, z in ((t_l, zupt_l), (t_r, zupt_r)):
        starts, stops = runs(z)
        if settings.instants == "stance-midpoints":
            times.append(0.5 * (t[starts] + t[stops - 1]))
        else:
            tz = t[np.asarray(z, bool)]
            if tz.size:
                # the first sample of each new interval bin of each phase: one check per interval
                phase = np.searchsorted(t[starts], tz, side="right")
                bins = np.floor((tz - t[starts][phase - 1]) / settings.stance_check_interval_s)
                first = np.ones(tz.size, bool)
                first[1:] = (phase[1:] != phase[:-1]) | (bins[1:] != bins[:-1])
                times.append(tz[first])
    out = np.unique(np.concatenate(times)) if times else np.zeros(0)
    lo, hi = max(t_l[0], t_r[0]), min(t_l[-1], t_r[-1])
    return out[(out >= lo) & (out <= hi)]


def check_filter(filter_settings) -> None:
    """The fusion weighs the feet by their covariance: refuse the paper mode's constant gain (``InputError``)."""
    if filter_settings.mode == "riccati":
        raise InputError(f"two-boot fusion needs the time-varying filter (--mode {filter_settings.mode} has a constant "
                         "gain and no covariance to weight the two feet with); drop --mode")


def _navigator(foot: FootInput, fs):
    """The navigator of ``fs.engine`` fed with the ZUPT mask directly (onset delay applied here, on the whole
    mask)."""
    from bootnav.postproc.ins.prepare import delay_zupt_onsets
    from bootnav.postproc.ins.prepare import prepare_filter

    if foot.init_yaw_sigma_rad is not None:
        fs = dataclasses.replace(fs, init_yaw_sigma_rad=float(foot.init_yaw_sigma_rad))
    dt = time_base(foot.t_s).nominal_dt_s  # as run_filter: the median step of the record
    zupt = delay_zupt_onsets(foot.t_s, np.asarray(foot.stance, bool), fs.zupt_onset_delay_s,
                             fs.zupt_onset_max_fraction)
    setup = prepare_filter(foot.init, foot.gravity, fs, dt)
    if fs.engine == "reference":
        from bootnav.postproc.ins.filterpy_engine import ReferenceNavigator

        return ReferenceNavigator(fs, setup, dt), zupt
    from bootnav.postproc.ins.stream import StreamNavigator

    return StreamNavigator(fs, setup, dt, apply_onset_delay=False), zupt


def fuse(left: FootInput, right: FootInput, filter_settings, settings: TwoBootSettings,
         progress: Callable[[float], None] | None = None) -> FusionOutput:
    """Run both feet in lockstep with the maximum-separation constraint (module docstring).

    Parameters
    ----------
    left, right
        Each foot's inputs on the session clock, in one navigation frame.
    filter_settings
        ``FilterSettings`` of both filters (the time-varying mode: the paper's constant gain has no
        covariance to weight a projection with).
    settings
        ``TwoBootSettings``.
    progress
        ``progress(fraction)``, called a few times.

    Returns
    -------
    FusionOutput

    Raises
    ------
    InputError
        The recordings do not overlap in time, or the filter is in the paper (riccati) mode.
    """
    from bootnav.postproc.ins.stream import NavRows

    settings.validate()
    check_filter(filter_settings)
    if min(left.t_s[-1], right.t_s[-1]) <= max(left.t_s[0], right.t_s[0]):
        raise InputError(f"the two boots' recordings do not overlap in time (left {left.t_s[0]:.1f}-"
                         f"{left.t_s[-1]:.1f} s, right {right.t_s[0]:.1f}-{right.t_s[-1]:.1f} s on the session clock); give --right-offset-s "
                         "or --clock gait")
    t0 = time.perf_counter()
    feet = (left, right)
    navs, zupts = zip(*(_navigator(f, filter_settings) for f in feet))
    instants = constraint_instants(left.t_s, zupts[0], right.t_s, zupts[1], settings)
    ends = [np.searchsorted(f.t_s, instants, side="right") for f in feet]
    done = [0, 0]
    rows: list[list] = [[], []]
    n_checks = n_active = n_gated = 0
    max_sep = 0.0
    n_states = filter_settings.n_states

    def push_to(i: int, k: int) -> None:
        if k > done[i]:
            f = feet[i]
            sl = slice(done[i], k)
            sat = None if f.saturated is None else np.asarray(f.saturated)[sl]
            rows[i].append(navs[i].push(f.t_s[sl], f.acc_b[sl], f.gyro_b[sl], zupts[i][sl], sat))
            done[i] = k

    report = max(1, len(instants) // 10)
    for j in range(len(instants)):
        push_to(0, int(ends[0][j]))
        push_to(1, int(ends[1][j]))
        if navs[0].last_index < 0 or navs[1].last_index < 0:
            continue
        n_checks += 1
        pl, pr = navs[0].position_n + left.start_n, navs[1].position_n + right.start_n
        covs = (navs[0].position_cov_n, navs[1].position_cov_n)
        proj = project_max_separation(pl, covs[0], pr, covs[1], settings.max_separation_m)
        max_sep = max(max_sep, proj.separation_m)
        if proj.active:
            n_active += 1
            u = proj.direction
            var_foot = [float(u @ c @ u) for c in covs]
            r_sep = separation_variance_m2(proj.separation_m - settings.max_separation_m, sum(var_foot),
                                           settings.constraint_sigma_m, settings.constraint_gate_sigma)
            n_gated += r_sep > settings.constraint_sigma_m ** 2
            for nav, p_hat, p_star, v in ((navs[0], pl, proj.p_left, var_foot[0]), (navs[1], pr, proj.p_right,
                                                                                     var_foot[1])):
                # each foot's share of R, so that the two scalar updates make the joint one
                r_foot = max(settings.constraint_sigma_m ** 2, r_sep * v / max(sum(var_foot), 1e-300))
                nav.apply_measurement(*position_measurement(p_hat, p_star, u, n_states, math.sqrt(r_foot)))
        if progress is not None and j % report == 0:
            progress(j / max(len(instants), 1))
    for i, f in enumerate(feet):
        push_to(i, len(f.t_s))
        rows[i].append(navs[i].finish())
    fused = []
    for i, f in enumerate(feet):
        r = NavRows.concatenate(rows[i])
        fused.append(FusedFoot(f.label, f.t_s, r.pos_n + f.start_n, r.vel_n, r.q_nb, r.acc_bias_b, r.gyro_bias_b,
                               r.pos_sigma_n, np.asarray(f.stance, bool), navs[i].info, r.pos_cov_en))
    if progress is not None:
        progress(1.0)
    return FusionOutput(fused[0], fused[1], n_checks, n_active, max_sep, time.perf_counter() - t0, n_gated)
