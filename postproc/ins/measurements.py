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

from bootnav.postproc.ins.layout import (BIAS_GYRO, DBG, DP, DV, HDE_HAVE_PREV, HDE_PREV_X, HDE_PREV_Y,
                                         HDE_REF_HEADING, POS, VEL, YAW)
from bootnav.postproc.ins.params import KernelParams
from bootnav.postproc.ins.settings import FilterSettings

# registry ids = position in REGISTRY (also the index of each model's active flag and update counter)
ZUPT, ZARU, HEADING_AID = 0, 1, 2
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
    threshold (a stride along a corridor, off by the heading drift only). A heuristic for buildings with
    rectilinear floor plans [Borenstein2009], not a sensor: off by default. Updates the heading-aid memory
    in ``st`` (layout.py) with the position corrected by the earlier updates of this sample.
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
                if abs(e) < prm.hde_threshold_rad:
                    z[0] = -e
                    m = 1
    st[HDE_PREV_X], st[HDE_PREV_Y], st[HDE_HAVE_PREV] = px, py, 1.0
    return m, YAW, prm.var_hde


@njit(cache=True, inline="always")
def measure(kind, st, dx, acc_b, gyro_b, stance, k, prm, z):
    """Evaluate the model with registry id ``kind`` (module docstring): returns (m, first, r), fills z[:m]."""
    if kind == ZUPT:
        return zupt(st, dx, acc_b, gyro_b, stance, k, prm, z)
    if kind == ZARU:
        return zaru(st, dx, acc_b, gyro_b, stance, k, prm, z)
    return heading_aid(st, dx, acc_b, gyro_b, stance, k, prm, z)


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


# application order within a sample: ZUPT, then ZARU, then the heading aid
REGISTRY: tuple[type[Measurement], ...] = (ZuptMeasurement, ZaruMeasurement, HeadingAidMeasurement)


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
