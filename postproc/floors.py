"""Storeys: stair flights counted in risers, and the height kept on discrete storeys where the evidence agrees.

The filter already holds the height on level strides (``ins.measurements.level_height``): on a floor the
height does not drift. What is left is the error of the climbs themselves (scale and misalignment errors of
an uncalibrated sensor act most during the large vertical accelerations of a stair stride), a few cm to a
few dm per flight, and it accumulates over a mission that goes up and down many times. Buildings quantise
height: a flight is a whole number of risers of 0.15–0.20 m (issue 24; building codes allow about 0.14–0.20 m), and a walker who comes back to a
floor is at that floor's height again. This stage uses both, on the footprints of the smoothed path
(``strides.footprints``), after the filter:

0. **Rolls.** A footprint closer than ``min_stride_m`` horizontally to the next is the foot before it rolled
   onto its heel or toe (stairs down land toe-first): the rolled foot's footprint stands for both.
1. **Flights.** A stride (footprint to footprint) is *level* when |Δz| < ``level_max_dz_m`` (the filter's
   gate, half the lowest riser); a flight is a maximal run of consecutive non-level strides of one sign
   (a half landing in a U-shaped stairwell splits a storey into two flights). A single non-level stride is
   not a flight: when it changes the height by less than one riser (``riser_min_m``) it is the sensor, not
   the building (kneeling down to crawl, the first stride after a long stand or a turn in place: an
   uncalibrated unit's lone strides err by 8-15 cm, of one sign in a mission, and added up to 1.2 m over 30
   minutes; docs/tuning-log.md) and is put back on its floor; a riser or more is a step (a kerb), kept.
2. **Risers.** Each stride of a flight climbs n_i = max(1, round(|Δz_i| / r̂)) risers, r̂ the riser height
   estimated so far (the pooled Σ|H| / ΣN of the agreeing flights before, 0.175 m before the first). The
   flight's riser count N = Σ n_i and its climbed height H = Σ Δz_i *agree* when
   N r_min − r_min/2 ≤ |H| ≤ N r_max + r_min/2 (``riser_min_m``, ``riser_max_m``).
3. **Floors are flat.** The footprints of level strides are put at the height of the floor they are on (the
   start's, or the landing of the flight that led there): the filter's hold leaves a bounded wobble of a
   centimetre or two per stride (its gain is below one), which would otherwise be carried into the next
   flight's start and add up over a mission.
4. **Storeys.** Only when they agree, the landing height becomes the storey estimate start + sign(H) N r̂
   (r̂ now including this flight), and if a level already visited (the start's, or an earlier landing's) is
   within half a riser of it, exactly that level: coming back to a floor puts the walker at its height again.
   When they disagree nothing is forced: the landing keeps the filter's height (and is remembered as a level).
   The correction (landing target minus the filter's landing height) is spread over the flight in
   proportion to the height already climbed, and carried to every later sample: the path stays continuous.

Why it bounds the error: going up N risers and down the same N risers lands exactly where the walker started
(the same N r̂ both ways), whatever the sensor's vertical scale error; a revisit snaps out what is left. A
flight whose count and height disagree (an escalator, a ramp mistaken for stairs, a bad stride) is left as
the filter says. One Python iteration per stance phase (not per sample).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.ins.settings import FilterSettings
from bootnav.postproc.strides import FloorSettings, footprints

MIN_FLIGHT_STRIDES = 2  # a flight has at least two stair strides (three risers or more)
MIN_FLOOR_STRIDES = 6  # level strides in a row that make a storey: ≈ 6 m, longer than any stair landing (≤ 2.5 m)


@dataclass
class StoreyResult:
    """Per-footprint height corrections and what the flights said."""

    offset_fp: np.ndarray  # (K,) m, added to the footprint heights (and, interpolated, to every sample)
    climbed_fp: np.ndarray  # (K,) m, height climbed on agreeing flights up to each footprint (reported; the floor
    # numbers count the corrected footprint heights, which measured better: docs/tuning-log.md)
    flights: int  # flights found
    agreeing: int  # flights whose riser count and climbed height agree (their landings were set)
    snapped: int  # of those, landings put on a level visited before
    risers: int  # risers counted on the agreeing flights
    riser_m: float  # pooled riser estimate, m (NaN without an agreeing flight)
    lone_held: int = 0  # lone non-level strides of less than one riser put back on their floor
    storey_fp: np.ndarray | None = None  # (K,) storey number of each footprint (``storey_numbers``), 0 = start's
    storeys_m: np.ndarray | None = None  # heights of the storeys found, m (corrected footprint heights)

    def summary(self) -> dict:
        return {"flights": self.flights, "flights_agreeing": self.agreeing, "landings_on_known_level": self.snapped,
                "risers": self.risers, "lone_strides_held": self.lone_held,
                "riser_estimate_m": self.riser_m if np.isfinite(self.riser_m) else None,
                "max_correction_m": float(np.abs(self.offset_fp).max()) if len(self.offset_fp) else 0.0,
                "storeys_m": [round(float(v), 3) for v in (self.storeys_m if self.storeys_m is not None else [])]}


def storey_offsets(fp: np.ndarray, level_max_dz_m: float, riser_min_m: float, riser_max_m: float,
                   min_stride_m: float = FilterSettings.level_min_stride_m,
                   storey_merge_m: float = FloorSettings.hysteresis_m,
                   storey_m: float = FloorSettings.floor_height_m) -> StoreyResult:
    """Height corrections of the footprints (module docstring).

    Parameters
    ----------
    fp : (K, 3) footprints, m (the smoothed path's, in order); (K,) heights alone are accepted (no rolls).
    level_max_dz_m : a stride with |Δz| below this is level, m.
    riser_min_m, riser_max_m : the range of a riser's height, m.
    min_stride_m : a footprint closer than this (horizontally) to the next one is the foot before it rolled
        onto its heel or toe (``FilterSettings.level_min_stride_m``): it takes the next one's correction and
        is not a stride of its own.
    storey_merge_m : storeys found closer than this are one (``storey_numbers``; ``floor_hysteresis_m``), m.
    storey_m : nominal storey height (``floor_height_m``), m: the storey numbers when the storeys found do
        not give their spacing.
    """
    fp = np.asarray(fp, float)
    k_all = len(fp)
    if fp.ndim == 1:
        fp = np.column_stack((np.arange(k_all) * (min_stride_m + 1.0), np.zeros(k_all), fp))
    out = StoreyResult(np.zeros(k_all), np.zeros(k_all), 0, 0, 0, 0, float("nan"), 0, np.zeros(k_all, np.int64),
                       fp[:1, 2].copy())
    if k_all < 2:
        return out
    far = np.hypot(*np.diff(fp[:, :2], axis=0).T) >= min_stride_m
    kept = np.flatnonzero(np.append(far, True))  # the last footprint of every cluster of close ones
    z = fp[kept, 2]
    k_n = len(z)
    off = np.zeros(k_n)
    climb = np.zeros(k_n)
    climbed = 0.0
    if k_n < 2:
        out.storey_fp = np.zeros(k_all, np.int64)
        return out
    dz = np.diff(z)
    nonlevel = np.abs(dz) >= level_max_dz_m
    tol = 0.5 * riser_min_m
    levels = [z[0]]
    plateau = z[0]  # height of the floor (or landing) the walker is on, corrected
    sum_h, sum_n = 0.0, 0
    k = 0
    while k < k_n - 1:
        if not nonlevel[k]:
            off[k + 1] = plateau - z[k + 1]  # a level stride: on the same floor
            climb[k + 1] = climbed
            k += 1
            continue
        sgn = np.sign(dz[k])
        j = k
        while j < k_n - 1 and nonlevel[j] and np.sign(dz[j]) == sgn:
            j += 1
        # strides k..j-1 are the flight, footprint j its landing; one stride is a step (a kerb, kneeling
        # down, standing up), not a flight: left as the filter says
        offset = off[k]
        if j - k < MIN_FLIGHT_STRIDES:
            climb[k + 1:j + 1] = climbed
            if np.all(np.abs(dz[k:j]) < riser_min_m):  # less than one riser: not a step of the building
                off[k + 1:j + 1] = plateau - z[k + 1:j + 1]
                out.lone_held += j - k
            else:
                off[k + 1:j + 1] = offset
                plateau = z[j] + offset
            k = j
            continue
        r_hat = sum_h / sum_n if sum_n else 0.5 * (riser_min_m + riser_max_m)
        n_i = np.maximum(1, np.rint(np.abs(dz[k:j]) / r_hat)).astype(int)
        n_risers, height = int(n_i.sum()), float(z[j] - z[k])
        out.flights += 1
        start, land = plateau, z[j] + offset
        target = land
        agree = n_risers * riser_min_m - tol <= abs(height) <= n_risers * riser_max_m + tol
        if agree:
            sum_h, sum_n = sum_h + abs(height), sum_n + n_risers
            target = start + sgn * n_risers * (sum_h / sum_n)
            near = min(levels, key=lambda lv: abs(lv - target))
            if abs(near - target) < tol:
                target = near
                out.snapped += 1
            out.agreeing += 1
            out.risers += n_risers
        if min(abs(lv - target) for lv in levels) >= tol:
            levels.append(target)
        new_offset = offset + (target - land)
        frac = np.cumsum(np.abs(dz[k:j])) / max(np.abs(dz[k:j]).sum(), 1e-12)
        off[k + 1:j + 1] = offset + frac * (new_offset - offset)
        climb[k + 1:j + 1] = climbed + (frac * (target - start) if agree else 0.0)
        climbed = climb[j]
        plateau = target
        k = j
    out.riser_m = sum_h / sum_n if sum_n else float("nan")
    back = np.searchsorted(kept, np.arange(k_all))  # a dropped footprint: its cluster's last one
    out.offset_fp, out.climbed_fp = off[back], climb[back]
    number, heights = storey_numbers(z + off, level_max_dz_m, storey_merge_m, storey_m)
    out.storey_fp, out.storeys_m = number[back], heights - z[0]
    return out


def storey_numbers(z_m: np.ndarray, level_max_dz_m: float, merge_m: float,
                   storey_m: float = FloorSettings.floor_height_m,
                   min_floor_strides: int = MIN_FLOOR_STRIDES) -> tuple[np.ndarray, np.ndarray]:
    """The storey number of every footprint (0 = the first footprint's storey) and the storeys' heights.

    A storey is found where the walker walks on the level: a run of at least ``min_floor_strides`` consecutive
    level strides (a stairwell's half landing has two or three); its height is the run's median; runs within
    ``merge_m`` of each other are one storey (a floor revisited has the same corrected height). The storey
    height ĥ is the median spacing of adjacent storeys found that lies within a factor 1.5 of the nominal
    ``storey_m`` (``floor_height_m``; ``storey_m`` itself when none does: a stairwell climbed without walking
    the floors between). A storey found is numbered round(Δh / ĥ) from the start's; a footprint within
    ``merge_m`` of a storey found takes its number, any other (stairs, landings, floors passed through) round(Δh
    / ĥ). Counted this way a 3.5 m storey is not a storey off from the 4th floor up as it is with a nominal 3 m
    (docs/floors.md)."""
    z = np.asarray(z_m, float)
    if len(z) == 0:
        return np.zeros(0, np.int64), np.zeros(0)
    level = np.abs(np.diff(z)) < level_max_dz_m
    starts, stops = _runs(level)  # strides starts[i]..stops[i]-1 level: footprints starts[i]..stops[i]
    heights = [float(np.median(z[a:b + 1])) for a, b in zip(starts, stops) if b - a >= min_floor_strides]
    cand = np.sort(np.array(heights + [float(z[0])]))
    found = [cand[0]]
    for c in cand[1:]:
        if c - found[-1] > merge_m:
            found.append(c)
    found = np.array(found)
    gaps = np.diff(found)
    gaps = gaps[(gaps > storey_m / 1.5) & (gaps < storey_m * 1.5)]
    h = float(np.median(gaps)) if len(gaps) else float(storey_m)
    z0 = float(found[np.abs(found - z[0]).argmin()])
    near = np.abs(z[:, None] - found[None, :])
    k = near.argmin(axis=1)
    at = near[np.arange(len(z)), k] <= merge_m
    number = (np.where(at, found[k], z) - z0) / h
    return np.rint(number).astype(np.int64), found


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop (exclusive) indices of the runs of True in ``mask``."""
    d = np.diff(np.concatenate(([0], np.asarray(mask, np.int8), [0])))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def snap_storeys(t_s: np.ndarray, pos_n: np.ndarray, stance: np.ndarray, level_max_dz_m: float, riser_min_m: float,
                 riser_max_m: float, min_stride_m: float = FilterSettings.level_min_stride_m,
                 storey_merge_m: float = FloorSettings.hysteresis_m,
                 storey_m: float = FloorSettings.floor_height_m) -> tuple[np.ndarray, StoreyResult]:
    """The path with its heights corrected (a new array; ``pos_n`` is not modified) and the flights' report.

    Each sample gets the correction interpolated in time between the footprints' mid times (constant on a
    floor, spread along a flight; before the first / after the last footprint, theirs)."""
    t_mid, fp = footprints(np.asarray(t_s, float), np.asarray(pos_n, float), stance)
    res = storey_offsets(fp, level_max_dz_m, riser_min_m, riser_max_m, min_stride_m, storey_merge_m, storey_m)
    out = np.array(pos_n, dtype=float, copy=True)
    out[:, 2] += sample_offsets(t_s, t_mid, res.offset_fp)
    return out, res


def sample_offsets(t_s: np.ndarray, t_mid: np.ndarray, offset_fp: np.ndarray) -> np.ndarray:
    """The height correction of every sample of ``t_s`` (any block of the recording, in any order): the
    footprints' ``offset_fp`` (``storey_offsets``) interpolated between their mid times ``t_mid``, held before
    the first and after the last. A block pipeline runs ``storey_offsets`` once on all footprints (K rows, one
    per stance phase: memory flat in the samples) and corrects each block with this."""
    t_s = np.asarray(t_s, float)
    if len(t_mid) == 0 or not np.any(offset_fp):
        return np.zeros(len(t_s))
    return np.interp(t_s, t_mid, offset_fp)
