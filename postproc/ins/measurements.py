"""Measurement models of the ZUPT filter, defined once and shared by both engines (pyins style [Mayorov-pyins]).

A measurement model says, for the nominal state x̂ and sample k, what it measures about the error state δx:

    z = H δx + ν,   ν ~ N(0, R),   H = [0 … I_m … 0] (selects m error states from ``first`` on),  R = r I_m

Each model is one numba function with the same signature

    model(st, dx, acc_b, gyro_b, stance, k, prm, z) -> (m, first, r)

reading the nominal state ``st`` (layout.py), the error estimate ``dx`` of this sample so far (models run
sequentially: a later one sees the earlier corrections), the sample (``acc_b[k]``, ``gyro_b[k]``,
``stance``) and the parameters ``prm`` (``params.KernelParams``). It writes z into ``z[:m]`` and returns the
number of rows m (0: does not apply at this sample), the first error-state index H selects, and the
variance r. Each model decides itself when it applies. Both engines run the active models in registry order
after the time update of every sample, each as a sequential Kalman update with the innovation z − H dx:

* the fast engine (``fast.py``) calls ``measure(kind, …)`` in its numba loop, unrolled over ``KERNEL_REGISTRY``
  so that every model's H is a compile-time index block (``kalman.py``: no H matrix);
* the reference engine (``filterpy_engine.py``) calls the very same jitted ``measure`` through the thin classes
  below (``ZuptMeasurement`` …), which return dense ``z, H, R`` for filterpy's ``KalmanFilter.update``.

Adding a measurement (e.g. a per-recording self-tuned noise, or a pseudo-measurement of a new state):

1. write its model function here (new numbers go into ``KernelParams``);
2. give it the next id and a branch in ``measure``;
3. append a thin ``Measurement`` subclass with its ``active(settings)`` rule to ``REGISTRY``.

Neither engine is edited. The fast engine's closed forms take m ∈ {1, 3}; a model whose H is not a
selection of states (e.g. a constraint on a difference of states) needs a general update in ``kalman.py``.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from bootnav.postproc.ins.layout import (BIAS_GYRO, DBG, DP, DV, HDE_GATE, HDE_HAVE_PREV, HDE_PREV_X, HDE_PREV_Y,
                                         HDE_REF_HEADING, HEIGHT, LVL_HAVE_REF, LVL_LAST_X, LVL_LAST_Y, LVL_PENDING,
                                         LVL_REF_Z, POS, VEL, YAW)
from bootnav.postproc.ins.params import KernelParams
from bootnav.postproc.ins.settings import FilterSettings

# registry ids = position in REGISTRY (also the index of each model's active flag and update counter)
ZUPT, ZARU, HEADING_AID, LEVEL_HEIGHT = 0, 1, 2, 3
MAX_ROWS = 3  # size of the z buffer the engines pass


@njit(cache=True, inline="always")
def zupt(st, dx, acc_b, gyro_b, stance, k, prm, z):
    """Zero-velocity update in stance: z = 0 − v̂ = δv + ν, H selects δv [Foxlin2005; Skog2010; Heidari2019, eq. 3].

    Rolling-foot noise: R = (σ_zupt² + (r |ω_k − b̂_g|)²) I — a foot rolling over heel or toe at rate ω moves
    the sensor at ≈ ω r, so zero velocity is only that certain at the edges of a stance phase.
    """
    if not stance[k]:
        return 0, DV, 0.0
    ib, iv = BIAS_GYRO.start, VEL.start
    wx, wy, wz = gyro_b[k, 0] - st[ib], gyro_b[k, 1] - st[ib + 1], gyro_b[k, 2] - st[ib + 2]
    z[0], z[1], z[2] = -st[iv], -st[iv + 1], -st[iv + 2]
    return 3, DV, prm.var_zupt + prm.lever_arm2 * (wx * wx + wy * wy + wz * wz)


@njit(cache=True, inline="always")
def zaru(st, dx, acc_b, gyro_b, stance, k, prm, z):
    """Zero-angular-rate update in stance: z = ω_m − b̂_g = δb_g + ν (the foot is not turning), H selects δb_g.

    Quiet-core noise: R = (σ_zaru² + (c |ω_k − b̂_g|)²) I — a rolling foot's own rate counts as noise, so the
    update only bites where the foot is really still. Needs the 15-state model.
    """
    if not stance[k]:
        return 0, DBG, 0.0
    ib = BIAS_GYRO.start
    wx, wy, wz = gyro_b[k, 0] - st[ib], gyro_b[k, 1] - st[ib + 1], gyro_b[k, 2] - st[ib + 2]
    z[0], z[1], z[2] = wx, wy, wz
    return 3, DBG, prm.var_zaru + prm.zaru_rate_factor2 * (wx * wx + wy * wy + wz * wz)


@njit(cache=True)
def hde_error(dx_m, dy_m, ref_rad):
    """Stride heading minus the nearest of the four directions ref + m·90° (rad, in (−45°, 45°])."""
    e = math.atan2(dy_m, dx_m) - ref_rad
    e = math.atan2(math.sin(e), math.cos(e))
    return e - math.floor(e / (0.5 * math.pi) + 0.5) * (0.5 * math.pi)


@njit(cache=True, inline="always")
def heading_aid(st, dx, acc_b, gyro_b, stance, k, prm, z):
    """Heuristic dominant-direction heading aid, at stance onsets: z = −e = δθ_U + ν, H selects yaw, R = σ_hde².

    e = heading of the stride since the previous stance onset minus the nearest of four directions 90° apart
    (the first stride of at least ``hde_min_stride_m`` sets the reference); applied only when |e| is below the
    threshold (a stride along a corridor, off by the heading drift only) and the per-segment gate
    ``st[HDE_GATE]`` is open (``building.directions.segment_gate``: a straight leg along the building's grid).
    A heuristic for buildings with rectilinear floor plans [Borenstein2009], not a sensor: off by default.
    Updates the heading-aid memory in ``st`` (layout.py) with the position corrected by the earlier updates of
    this sample, gate open or not.
    """
    if not stance[k] or (k > 0 and stance[k - 1]):
        return 0, YAW, 0.0
    px, py = st[POS.start] + dx[DP], st[POS.start + 1] + dx[DP + 1]
    m = 0
    if st[HDE_HAVE_PREV] > 0.5:
        sx, sy = px - st[HDE_PREV_X], py - st[HDE_PREV_Y]
        if math.sqrt(sx * sx + sy * sy) >= prm.hde_min_stride_m:
            if math.isnan(st[HDE_REF_HEADING]):
                st[HDE_REF_HEADING] = math.atan2(sy, sx)
            else:
                e = hde_error(sx, sy, st[HDE_REF_HEADING])
                if abs(e) < prm.hde_threshold_rad and st[HDE_GATE] > 0.5:
                    z[0] = -e
                    m = 1
    st[HDE_PREV_X], st[HDE_PREV_Y], st[HDE_HAVE_PREV] = px, py, 1.0
    return m, YAW, prm.var_hde


@njit(cache=True, inline="always")
def level_height(st, dx, acc_b, gyro_b, stance, k, prm, z):
    """Height hold on a level stride, at stance onsets: z = h_ref − ĥ = δp_U + ν, H selects δp_U, R = σ_level².

    h_ref is the height of the floor the foot stood on (``LVL_REF_Z``, layout.py); ĥ the nominal height p̂_U.
    The gate and the memory use the height after the earlier updates of this sample (the ZUPT), p̂_U + δp_U;
    z does not add δp_U again, since the sequential update's innovation is z − δp_U (``kalman``). A stride
    is *level* when its estimated height change
    |ĥ − h_ref| is below ``level_max_dz_m`` (half the lowest riser): the foot's own motion tells a flat
    stride from a stair stride [MunozDiaz2018], and the drift of one stride is far below a riser. Then the
    walker is on the same floor, and the height change since the last footfall is zero up to the floor's
    flatness; the reference is kept (a level walk never random-walks the floor's height). Any other stride
    (stairs, a ramp) gets no measurement, and the new reference is the height where the foot settles: it
    follows the foot through the rest of that stance phase (``LVL_PENDING``; the ZUPTs after the onset still
    move the height by millimetres to a centimetre after a stair swing). The first stance phase sets the
    first reference the same way. After a stair stride, a move shorter than ``level_min_stride_m``
    horizontally is not a stride but the foot rolling onto its heel (stairs down land toe-first), which
    changes the sensor's height by centimetres: no measurement, and the reference goes on following the foot
    to where it settles. On a floor, short moves (crawling, turning on the spot) are held like strides.

    Why R = σ_level² alone: h_ref is the filter's own earlier estimate, so its error is the same accumulated
    height error δh the current state carries (fully correlated), and z = h_ref − ĥ measures only the height
    change of this stride (the error it added since the last footfall), whose physical spread is the floor's
    flatness. Counting the reference's variance P_zz in R as if it were independent would halve every update
    and still collapse P_zz; the honest price of the exact (cloned-state) form is a vertical σ that reports
    the last stride's uncertainty, not the mission's: ``docs/floors.md``. Horizontal states are touched only
    through their (small) correlation with δp_U.
    """
    if not stance[k]:
        return 0, HEIGHT, 0.0
    px, py = st[POS.start] + dx[DP], st[POS.start + 1] + dx[DP + 1]
    h = st[POS.start + 2] + dx[HEIGHT]
    if k > 0 and stance[k - 1]:  # within a stance phase: the reference follows the foot after a non-level stride
        if st[LVL_PENDING] > 0.5:
            st[LVL_REF_Z] = h
        st[LVL_LAST_X], st[LVL_LAST_Y] = px, py
        return 0, HEIGHT, 0.0
    sx, sy = px - st[LVL_LAST_X], py - st[LVL_LAST_Y]
    st[LVL_LAST_X], st[LVL_LAST_Y] = px, py
    m = 0
    if st[LVL_PENDING] > 0.5 and sx * sx + sy * sy < prm.level_min_stride_m * prm.level_min_stride_m:
        pass  # a heel or toe roll after a stair stride: no measurement, the reference still follows the foot
    elif st[LVL_HAVE_REF] > 0.5 and abs(h - st[LVL_REF_Z]) < prm.level_max_dz_m:
        # against the NOMINAL height: the update's innovation is z − δp_U with δp_U = dx[HEIGHT], the earlier
        # updates' correction (``kalman.sequential_update``), so z = h_ref − ĥ counted that correction twice
        z[0] = st[LVL_REF_Z] - st[POS.start + 2]
        m = 1
        st[LVL_PENDING] = 0.0
    else:
        st[LVL_REF_Z], st[LVL_HAVE_REF], st[LVL_PENDING] = h, 1.0, 1.0
    return m, HEIGHT, prm.var_level


@njit(cache=True, inline="always")
def measure(kind, st, dx, acc_b, gyro_b, stance, k, prm, z):
    """Evaluate the model with registry id ``kind`` (module docstring): returns (m, first, r), fills z[:m]."""
    if kind == ZUPT:
        return zupt(st, dx, acc_b, gyro_b, stance, k, prm, z)
    if kind == ZARU:
        return zaru(st, dx, acc_b, gyro_b, stance, k, prm, z)
    if kind == HEADING_AID:
        return heading_aid(st, dx, acc_b, gyro_b, stance, k, prm, z)
    return level_height(st, dx, acc_b, gyro_b, stance, k, prm, z)


class Measurement:
    """A registered model as z, H, R for a state (for the reference engine, readers and tests).

    Parameters
    ----------
    params : the run's kernel parameters.
    n_states : size of the error state (9 or 15): the width of H.
    """

    kind: int = -1
    name: str = ""

    def __init__(self, params: KernelParams, n_states: int):
        self.params = params
        self.n_states = n_states
        self._z = np.zeros(MAX_ROWS)
        self._h = {}  # (m, first) -> H: a selection, the same at every sample

    @staticmethod
    def active(settings: FilterSettings) -> bool:
        """Whether a run with these settings applies this measurement."""
        raise NotImplementedError

    def evaluate(self, st, dx, acc_b, gyro_b, stance, k):
        """The measurement at sample k, or None where it does not apply.

        Parameters
        ----------
        st : (N_NOMINAL,) nominal state (layout.py); the heading aid updates its memory slots.
        dx : (n_states,) error estimate of this sample so far (sequential updates).
        acc_b, gyro_b : (N, 3) the record's samples; stance : (N,) bool ZUPT mask; k : sample index.

        Returns
        -------
        (z (m,), H (m, n_states), R (m, m)) or None.
        """
        m, first, r = measure(self.kind, st, dx, acc_b, gyro_b, stance, k, self.params, self._z)
        if m == 0:
            return None
        h = self._h.get((m, first))
        if h is None:
            h = self._h[(m, first)] = np.zeros((m, self.n_states))
            h[:, first:first + m] = np.eye(m)
        return self._z[:m].copy(), h, np.eye(m) * r


class ZuptMeasurement(Measurement):
    """Zero velocity in stance, rolling-foot R (``zupt``). In the paper (Riccati) mode the engines apply the
    constant Riccati gain to this model's z instead of a Kalman update, so it is not "active" there."""

    kind, name = ZUPT, "zupt"

    @staticmethod
    def active(settings: FilterSettings) -> bool:
        return settings.mode == "time_varying"


class ZaruMeasurement(Measurement):
    """Zero angular rate in stance, quiet-core R (``zaru``); needs the gyro-bias states (15, time-varying)."""

    kind, name = ZARU, "zaru"

    @staticmethod
    def active(settings: FilterSettings) -> bool:
        return bool(settings.zaru and settings.n_states == 15 and settings.mode == "time_varying")


class HeadingAidMeasurement(Measurement):
    """Dominant-direction yaw pseudo-measurement at stance onsets (``heading_aid``), optional."""

    kind, name = HEADING_AID, "heading_aid"

    @staticmethod
    def active(settings: FilterSettings) -> bool:
        return settings.heading_aid == "dominant_directions"


class LevelHeightMeasurement(Measurement):
    """Zero height change of a level stride at stance onsets (``level_height``), on by default."""

    kind, name = LEVEL_HEIGHT, "level_height"

    @staticmethod
    def active(settings: FilterSettings) -> bool:
        return bool(settings.level_height and settings.mode == "time_varying")


# application order within a sample: ZUPT, then ZARU, then the heading aid, then the height hold
REGISTRY: tuple[type[Measurement], ...] = (ZuptMeasurement, ZaruMeasurement, HeadingAidMeasurement,
                                           LevelHeightMeasurement)


def active_measurements(settings: FilterSettings, params: KernelParams) -> list[Measurement]:
    """The measurements a run with ``settings`` applies, in registry order (reference engine)."""
    return [cls(params, settings.n_states) for cls in REGISTRY if cls.active(settings)]


def _kernel_entry(cls: type[Measurement]):
    """The fast kernel's registry entry of a model: its id, in a tuple type of its own, so that numba's
    ``literal_unroll`` compiles one specialised copy of the update per model."""
    return namedtuple(f"{cls.__name__}Entry", ("kind",))(cls.kind)


KERNEL_REGISTRY = tuple(_kernel_entry(cls) for cls in REGISTRY)
N_KINDS = len(REGISTRY)


def active_flags(settings: FilterSettings) -> np.ndarray:
    """(N_KINDS,) bool: which models a run with ``settings`` applies, indexed by registry id (fast engine)."""
    return np.array([cls.active(settings) for cls in REGISTRY], dtype=np.bool_)
