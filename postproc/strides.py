"""Strides, distance, closure and floors from a ZUPT trajectory and its stance mask.

A foot-mounted sensor sees one *stride* per stance phase: the foot rests, swings, rests again. Stance
phase ``k`` is a maximal run of ``stance == True``; its *footprint* is the mean nav-frame position over
the run (after ZUPT/smoothing the foot is still there, so the mean only removes sample noise).
Stride ``k`` (k >= 1) goes from footprint ``k-1`` to footprint ``k``:

* ``t_s``: mid time of stance phase ``k``;
* ``x_m, y_m, z_m``: footprint ``k`` (ENU, origin at the start of the recording);
* ``stride_length_m``: horizontal distance ``‖(Δx, Δy)‖`` (the convention of the datasets' METRICS.md);
* ``dz_m``: height change ``Δz`` (stairs: riser height × steps per stride);
* ``heading_rad``: ``atan2(Δy, Δx)``, direction of the stride counter-clockwise from x (east).

Distance = Σ stride lengths (horizontal; ``distance_3d_m`` also reported). Closure (METRICS.md
``closed_loop``): footprint of the last stance phase minus that of the first; ``closure_pct = 100 ·
closure_3d_m / distance_m``.

Floors (seed-004 R17/R20: stairs without a flat-floor assumption): the footprint height relative to the
first footprint is turned into an integer floor level with hysteresis. Level ``L`` goes up when
``z > (L + ½)·h + hyst`` and down when ``z < (L − ½)·h − hyst`` (``h`` = floor height): a landing halfway
or a few centimetres of vertical drift never toggle the count. Floors climbed = number of up
transitions, descended = number of down transitions.

Optional stair gating (``stair_min_dz_m``): the height signal is then the running sum of only those stride
height changes with |Δz| ≥ ``stair_min_dz_m``. A stair stride climbs two risers (≈ 0.3 m), while the
vertical drift of a ZUPT INS adds millimetres per flat stride; gating removes hours of slow drift from the
floor count. The price: a gentle ramp (|Δz| per stride below the gate) never counts as a floor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STEP_COLUMNS = ("t_s", "x_m", "y_m", "z_m", "stride_length_m", "dz_m", "heading_rad")


def stance_phases(stance: np.ndarray) -> np.ndarray:
    """(K, 2) int array of [start, stop) sample indices of each run of True."""
    s = np.asarray(stance, dtype=bool).astype(np.int8)
    edges = np.diff(np.concatenate(([0], s, [0])))
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1)
    return np.column_stack((starts, stops)).astype(np.int64)


def footprints(t_s: np.ndarray, pos_n: np.ndarray, phases: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mid time (K,) and mean position (K, 3) of each stance phase (vectorised with cumulative sums)."""
    if len(phases) == 0:
        return np.zeros(0), np.zeros((0, 3))
    csum = np.vstack((np.zeros((1, 3)), np.cumsum(pos_n, axis=0)))
    n = (phases[:, 1] - phases[:, 0])[:, None]
    mean = (csum[phases[:, 1]] - csum[phases[:, 0]]) / n
    t_mid = 0.5 * (t_s[phases[:, 0]] + t_s[phases[:, 1] - 1])
    return t_mid, mean


def segment_strides(t_s: np.ndarray, pos_n: np.ndarray, stance: np.ndarray) -> dict[str, np.ndarray]:
    """One row per stride (dict of equal-length arrays, keys ``STEP_COLUMNS``)."""
    phases = stance_phases(stance)
    t_mid, fp = footprints(np.asarray(t_s, float), np.asarray(pos_n, float), phases)
    d = np.diff(fp, axis=0)
    return {
        "t_s": t_mid[1:],
        "x_m": fp[1:, 0],
        "y_m": fp[1:, 1],
        "z_m": fp[1:, 2],
        "stride_length_m": np.hypot(d[:, 0], d[:, 1]),
        "dz_m": d[:, 2],
        "heading_rad": np.arctan2(d[:, 1], d[:, 0]),
    }


@dataclass
class FloorSettings:
    """Floor counting from cumulative height.

    floor_height_m: storey height h (m); the paper's building is unknown, 3 m is a typical storey.
    stair_min_dz_m: None = count floors from the footprint height; a value (m) = from stair strides only
        (|Δz| >= this), see the module docstring.
    hysteresis_m: extra height beyond the half-storey boundary before a level change counts (m).
    """

    floor_height_m: float = 3.0
    hysteresis_m: float = 0.5
    stair_min_dz_m: float | None = None

    def __post_init__(self):
        if not self.floor_height_m > 0:
            raise ValueError(f"floor_height_m must be > 0, got {self.floor_height_m}")
        if self.stair_min_dz_m is not None and not 0 < self.stair_min_dz_m < self.floor_height_m:
            raise ValueError(f"stair_min_dz_m must be None or in (0, floor_height_m), got {self.stair_min_dz_m}")
        if not 0 <= self.hysteresis_m < self.floor_height_m / 2:
            raise ValueError(
                f"hysteresis_m must be in [0, floor_height_m/2) = [0, {self.floor_height_m / 2}), got {self.hysteresis_m}"
            )


def floor_signal(z_rel_m: np.ndarray, settings: FloorSettings) -> np.ndarray:
    """Height (m, relative to the first footprint) used for counting floors: the footprint height, or the
    running sum of stair-stride height changes when ``stair_min_dz_m`` is set."""
    z = np.asarray(z_rel_m, float)
    if settings.stair_min_dz_m is None or len(z) < 2:
        return z
    dz = np.diff(z)
    return np.concatenate(([0.0], np.cumsum(np.where(np.abs(dz) >= settings.stair_min_dz_m, dz, 0.0))))


def floor_levels(z_rel_m: np.ndarray, settings: FloorSettings) -> np.ndarray:
    """Integer floor level (0 = start) for each height sample, with hysteresis (see module docstring)."""
    h, hy = settings.floor_height_m, settings.hysteresis_m
    levels = np.zeros(len(z_rel_m), dtype=np.int64)
    level = 0
    # K footprints (one per stride), so a short Python loop is fine here.
    for i, z in enumerate(np.asarray(z_rel_m, float)):
        while z > (level + 0.5) * h + hy:
            level += 1
        while z < (level - 0.5) * h - hy:
            level -= 1
        levels[i] = level
    return levels


def count_floors(z_rel_m: np.ndarray, settings: FloorSettings) -> dict:
    """Floors climbed/descended and the final level from footprint heights relative to the start."""
    levels = floor_levels(floor_signal(z_rel_m, settings), settings)
    steps = np.diff(np.concatenate(([0], levels)))
    return {
        "floors_climbed": int(steps[steps > 0].sum()),
        "floors_descended": int(-steps[steps < 0].sum()),
        "final_floor": int(levels[-1]) if len(levels) else 0,
        "floor_height_m": settings.floor_height_m,
        "floor_hysteresis_m": settings.hysteresis_m,
        "floor_stair_min_dz_m": settings.stair_min_dz_m,
    }


def path_summary(t_s: np.ndarray, pos_n: np.ndarray, stance: np.ndarray, floors: FloorSettings) -> dict:
    """Distance, closure, height and floors from stance phases (all in metres; see module docstring)."""
    phases = stance_phases(stance)
    _, fp = footprints(np.asarray(t_s, float), np.asarray(pos_n, float), phases)
    out: dict = {"stance_phases": int(len(phases)), "strides": max(int(len(phases)) - 1, 0)}
    if len(fp) < 2:
        out.update(distance_m=0.0, distance_3d_m=0.0)
        return out
    d = np.diff(fp, axis=0)
    dist = float(np.hypot(d[:, 0], d[:, 1]).sum())
    closure = fp[-1] - fp[0]
    z_rel = fp[:, 2] - fp[0, 2]
    out.update(
        distance_m=dist,
        distance_3d_m=float(np.linalg.norm(d, axis=1).sum()),
        closure_h_m=float(np.hypot(closure[0], closure[1])),
        closure_v_m=float(abs(closure[2])),
        closure_3d_m=float(np.linalg.norm(closure)),
        closure_pct=float(100.0 * np.linalg.norm(closure) / dist) if dist > 0 else float("nan"),
        height_change_m=float(z_rel[-1]),
        height_max_m=float(z_rel.max()),
        height_min_m=float(z_rel.min()),
        mean_stride_length_m=float(np.hypot(d[:, 0], d[:, 1]).mean()),
        duration_walked_s=float(t_s[phases[-1, 0]] - t_s[phases[0, 1] - 1]),
    )
    out.update(count_floors(z_rel, floors))
    return out
