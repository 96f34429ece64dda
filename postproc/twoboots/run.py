"""``process_two_boots``: two foot recordings of one walker → both fused foot paths, the walker's path, gait.

Stages:

1. **each foot alone**: ``pipeline.process`` (load, checks, calibration, stance detection with its fallback,
   the vertical timing calibration, filter + smoother, strides): the single-foot results, kept for comparison,
   and the stance mask, specific force and initial state the fusion reuses, so the only difference between a
   foot's single and fused path is the constraint;
2. **one clock** (``align.gait_clock_offset``): the right foot's ``t_s`` + ``right_offset_s``; the gait-symmetry
   offset is always reported, and added with ``clock="gait"``;
3. **one frame** (``align.heading_offset_rad``): the right foot's initial yaw turned onto the left's;
4. **fusion** (``fusion.fuse``): both navigators in lockstep with the maximum-separation constraint [Skog2012];
5. **storeys** (``floors.snap_storeys``, when ``floor_storeys``): each fused foot's height on storeys, as
   ``process`` does for one foot (the fusion re-runs both filters, so the single runs' storeys do not carry);
6. **walker and gait** (``gaitmetrics``): the midpoint path, per-foot strides with step width, floor and the
   1-σ ellipse (``foot_covariance``), distance, floors (``strides.path_summary``) of each foot and of the walker.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from bootnav.core.conventions import CONVENTIONS, SOFTWARE
from bootnav.errors import InputError
from bootnav.logger.recording import Recording

from . import align
from .fusion import FootInput, FusionOutput, check_filter, fuse
from .gaitmetrics import gait_table, walker_path
from .settings import TwoBootSettings

LABELS = ("left", "right")


@dataclass
class TwoBootResult:
    """Everything a two-boot run produced (SI, ENU, the left foot's frame and the session clock)."""

    single: dict[str, Any]  # label -> pipeline.ProcessResult (each foot alone, its own frame and clock)
    fused: FusionOutput
    walker_t_s: np.ndarray
    walker_pos_n: np.ndarray
    gait: dict  # label -> stride table with step_width_m (gaitmetrics.gait_table)
    clock: dict
    heading: dict
    settings: Any  # ProcessSettings of both feet
    two_boot: TwoBootSettings
    summary: dict = field(default_factory=dict)
    names: dict = field(default_factory=dict)  # label -> input name


def foot_input(label: str, res, offset_s: float = 0.0, yaw_rad: float = 0.0, start_n=None,
               yaw_sigma_rad: float | None = None) -> FootInput:
    """The fusion's inputs of one foot from its single-foot ``ProcessResult`` (clock shift, frame yaw, start)."""
    init = dataclasses.replace(res.init, q_nb=align.rotate_yaw_quat(res.init.q_nb, yaw_rad)) if yaw_rad else res.init
    return FootInput(label, np.asarray(res.t_s, float) + offset_s, np.asarray(res.navigation.acc_used_b, float),
                     np.asarray(res.gyro_b, float), np.asarray(res.stance, bool), init, float(res.gravity_mps2),
                     res.saturation_bits, np.zeros(3) if start_n is None else np.asarray(start_n, float),
                     yaw_sigma_rad)


def common_frame_covariance(f, single, settings, yaw_rad: float = 0.0,
                            yaw_sigma_rad: float | None = None) -> np.ndarray | None:
    """The conservative per-foot horizontal covariance (K, 3) = (EE, NN, EN), m², at the end of each stance phase of
    the fused foot ``f``: its single-foot filter covariance (the same stance mask, so the same stance-phase ends)
    turned into the common frame by the frame alignment ``yaw_rad`` (P' = R P Rᵀ), plus, for a foot whose frame
    was aligned, the rest of the alignment's yaw variance (``yaw_sigma_rad``² − ``init_yaw_sigma_rad``², the
    variance the fused navigator starts with instead) as a rotation of the path about its first footprint
    (``ellipses.scale_error_covariance``'s cross-axis term: the same first-order form). None when the single-foot
    run kept no covariance."""
    from bootnav.postproc.ellipses import scale_error_covariance, unwrapped_yaw
    from bootnav.postproc.strides import footprints, phase_ends

    nav = getattr(single, "nav", None)
    sig, cen = getattr(nav, "pos_sigma_n", None), getattr(nav, "pos_cov_en", None)
    if sig is None or cen is None:
        return None
    end = phase_ends(np.asarray(f.stance, bool))
    sig, cen = np.asarray(sig, float)[end], np.asarray(cen, float)[end]
    a, b = sig[:, 0] ** 2, sig[:, 1] ** 2
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    cov = np.column_stack((c * c * a - 2 * c * s * cen + s * s * b, s * s * a + 2 * c * s * cen + c * c * b,
                           c * s * (a - b) + (c * c - s * s) * cen))
    if yaw_sigma_rad is not None and len(end):
        rest = yaw_sigma_rad ** 2 - settings.filter.init_yaw_sigma_rad ** 2
        if rest > 0:
            _, fp = footprints(f.t_s, f.pos_n, f.stance)
            cov = cov + scale_error_covariance(fp, unwrapped_yaw(f.q_nb)[end], 0.0, math.sqrt(rest))
    return cov


def foot_covariance(f, single, settings, yaw_rad: float = 0.0, yaw_sigma_rad: float | None = None) -> dict:
    """The ellipse inputs of one fused foot for ``gaitmetrics.gait_table`` (docs/twoboots.md, "Stride ellipses").

    The fusion is two filters, not one joint filter: each foot's navigator takes the constraint as a position
    pseudo-measurement of accuracy ``constraint_sigma_m`` and keeps no covariance with the other foot, so after
    an update its own P claims to know the foot to centimetres along the constraint direction although the bound
    observes only the DIFFERENCE of the feet (the common mode stays as uncertain as before). So at each stance
    phase the filter part is the LARGER (by semi-major axis) of the conservative per-foot value
    (``common_frame_covariance``) and the fused navigator's own P (larger where the single-foot run had an aid
    the fused filters do not run, e.g. ``heading_aid``); to it is added the scale/cross-axis term of the fused
    path (``ellipses.stride_scale_covariance``, with the foot's own sensor calibration status). Returns {} when
    a covariance is missing.
    """
    from bootnav.postproc.ellipses import stride_scale_covariance
    from bootnav.postproc.strides import ellipse, phase_ends

    cons = common_frame_covariance(f, single, settings, yaw_rad, yaw_sigma_rad)
    if cons is None or f.pos_cov_en is None:
        return {}
    end = phase_ends(np.asarray(f.stance, bool))
    own = np.column_stack((f.pos_sigma_n[end, 0] ** 2, f.pos_sigma_n[end, 1] ** 2, f.pos_cov_en[end]))
    use_own = ellipse(*own.T)[0] > ellipse(*cons.T)[0]
    chosen = np.where(use_own[:, None], own, cons)
    sig = np.array(f.pos_sigma_n, float)  # the covariance at the stance ends is all ``segment_strides`` reads
    cen = np.array(f.pos_cov_en, float)
    sig[end, :2] = np.sqrt(np.maximum(chosen[:, :2], 0.0))
    cen[end] = chosen[:, 2]
    cal = getattr(single, "sensor_calibration", None)
    calibrated = cal is not None and cal.provenance.get("status") == "applied"
    return {"pos_sigma_n": sig, "pos_cov_en": cen,
            "cov_extra": stride_scale_covariance(f.t_s, f.pos_n, f.stance, f.q_nb, settings, calibrated)}


def _name(src) -> str:
    return Path(src.path).name if isinstance(src, Recording) and src.path else Path(str(src)).name


def process_two_boots(left: str | Path | Recording, right: str | Path | Recording, settings=None,
                      two_boot: TwoBootSettings | None = None,
                      progress: Callable[[str, float], None] | None = None) -> TwoBootResult:
    """Run the stages of the module docstring on a left and a right foot recording; writes nothing.

    Parameters
    ----------
    left, right
        Each foot's recording (a path ``process`` reads, or a ``Recording``, e.g. one boot of a multi-boot file).
    settings
        ``ProcessSettings`` of both feet (default ``ProcessSettings()``).
    two_boot
        ``TwoBootSettings`` (default ``TwoBootSettings()``).
    progress
        ``progress(stage, fraction)``.

    Returns
    -------
    TwoBootResult

    Raises
    ------
    InputError
        Whatever ``process`` refuses for either foot (the message names the file), recordings that do not
        overlap in time, the paper (riccati) mode.
    """
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    settings = settings or ProcessSettings()
    tb = two_boot or TwoBootSettings()
    tb.validate()
    check_filter(settings.filter)  # before the long single-foot runs
    check_two_feet(left, right)
    t0 = time.perf_counter()
    single = {}
    for label, src in zip(LABELS, (left, right)):
        sub = None if progress is None else (lambda stage, f, label=label: progress(f"{label}: {stage}", f))
        single[label] = process(src, settings, sub)
    result = fuse_results(single, settings, tb, {"left": _name(left), "right": _name(right)}, progress)
    result.summary["timings_s"]["each_foot_s"] = time.perf_counter() - t0 - result.summary["timings_s"]["total_s"]
    return result


def check_two_feet(left, right) -> None:
    """``InputError`` when the left and the right foot are one recording given twice (the same file, a byte-identical
    copy, or the same samples): a fusion of a foot with itself would report a perfect walker."""
    import filecmp

    from bootnav.core.paths import same_path

    def samples(x):
        return x.acc_mps2 if isinstance(x, Recording) else None

    if isinstance(left, (str, Path)) and isinstance(right, (str, Path)):
        a, b = Path(left), Path(right)
        same = same_path(a, b)
        if not same and a.is_file() and b.is_file() and a.stat().st_size == b.stat().st_size:
            same = filecmp.cmp(a, b, shallow=False)
        if same:
            raise InputError(f"{a} and {b} are the same recording; give the left and the right boot's recordings "
                             "(two different files, or one multi-boot recording)")
    elif samples(left) is not None and samples(right) is not None and left.acc_mps2.shape == right.acc_mps2.shape \
            and np.array_equal(left.acc_mps2, right.acc_mps2) and np.array_equal(left.t_s, right.t_s):
        raise InputError("the left and the right boot have the same samples: the same recording was given twice; "
                         "give each foot's own recording")


def fuse_results(single: dict, settings, tb: TwoBootSettings, names: dict | None = None,
                 progress: Callable[[str, float], None] | None = None) -> TwoBootResult:
    """Stages 2-5 (module docstring) from the two feet's single-foot ``ProcessResult`` s.

    Parameters
    ----------
    single
        ``{"left": ProcessResult, "right": ProcessResult}`` of ``pipeline.process`` with ``settings``.
    settings, tb
        ``ProcessSettings`` of both feet and ``TwoBootSettings``.
    names
        How the summary names the inputs.
    progress
        ``progress(stage, fraction)``.

    Returns
    -------
    TwoBootResult
    """
    from bootnav.postproc.floors import snap_storeys
    from bootnav.postproc.strides import path_summary

    tb.validate()
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    L, R = single["left"], single["right"]
    clock = align.gait_clock_offset(L.t_s, L.stance, R.t_s + tb.right_offset_s, R.stance)
    clock.update(mode=tb.clock, right_offset_s=tb.right_offset_s)
    offset = tb.right_offset_s + (clock["offset_s"] if tb.clock == "gait" and math.isfinite(clock["offset_s"]) else 0.0)
    clock["applied_offset_s"] = offset
    heading = align.heading_offset_rad(L.t_s, L.pos_n, R.t_s + offset, R.pos_n, tb.heading_alignment_m)
    fwd, lat = tb.right_start_m
    psi = heading["walk_yaw_rad"] if tb.right_start_frame == "walk" else 0.0
    right_start = np.array([fwd * math.cos(psi) - lat * math.sin(psi), fwd * math.sin(psi) + lat * math.cos(psi), 0.0])
    feet = (foot_input("left", L),
            foot_input("right", R, offset, heading["yaw_rad"], right_start, tb.heading_alignment_sigma_rad))
    t1 = time.perf_counter()
    fused = fuse(*feet, settings.filter, tb, None if progress is None else (lambda f: progress("fusion", f)))
    timings["fusion_s"] = time.perf_counter() - t1

    fl, fr = fused.left, fused.right
    floors = settings.floor_settings()
    storeys = {label: None for label in LABELS}
    floor_z = {label: None for label in LABELS}
    if floors.storeys:  # each fused foot on storeys, as a single foot's path is (``floors.snap_storeys``)
        for label, f in (("left", fl), ("right", fr)):
            f.pos_n, res_st = snap_storeys(f.t_s, f.pos_n, f.stance, settings.filter.level_max_dz_m,
                                           floors.riser_min_m, floors.riser_max_m, settings.filter.level_min_stride_m,
                                           floors.hysteresis_m, floors.floor_height_m)
            storeys[label] = res_st.summary()
            floor_z[label] = res_st.storey_fp * floors.floor_height_m  # the storeys' numbers (as ``process``)
    walker = walker_path(fl.t_s, fl.pos_n, fr.t_s, fr.pos_n)
    min_stride = settings.selftune.min_stride_m
    cov_args = {"left": {}, "right": {"yaw_rad": heading["yaw_rad"], "yaw_sigma_rad": tb.heading_alignment_sigma_rad}}
    gait = gait_table(*({"t_s": f.t_s, "pos_n": f.pos_n, "stance": f.stance,
                         **foot_covariance(f, single[label], settings, **cov_args[label])}
                        for label, f in (("left", fl), ("right", fr))), min_stride, floors=floors, floor_z=floor_z)
    result = TwoBootResult(single, fused, fl.t_s, walker, gait, clock, heading, settings, tb,
                           names=dict(names or {label: label for label in LABELS}))
    feet_summary = {}
    for label, f in (("left", fl), ("right", fr)):
        s = single[label]
        feet_summary[label] = {
            "input": result.names[label],
            "single": path_summary(s.t_s, s.pos_n, s.stance, floors, min_stride),
            "fused": {**path_summary(f.t_s, f.pos_n, f.stance, floors, min_stride, floor_z[label]),
                      "storeys": storeys[label]},
            "mean_step_width_m": _nanmean(gait[label]["step_width_m"]),
            "mean_stride_length_m": _nanmean(gait[label]["stride_length_m"]),
            "stance_choice": s.navigation.choice,
            "confidence": s.navigation.confidence,
        }
    timings["total_s"] = time.perf_counter() - t0
    result.summary = {
        "software": dict(SOFTWARE),
        "conventions": CONVENTIONS,
        "method": "maximum-separation constraint between two foot-mounted ZUPT filters [Skog2012]",
        "engine": settings.filter.engine,
        "feet": feet_summary,
        "walker": {"distance_m": 0.5 * sum(feet_summary[k]["fused"].get("distance_m", 0.0) for k in LABELS),
                   "distance_rule": "mean of the two fused feet's stride distances"},
        "constraint": {"checks": fused.n_checks, "active_updates": fused.n_active, "gated_updates": fused.n_gated,
                       "max_separation_before_m": fused.max_separation_before_m,
                       "bound_m": tb.max_separation_m},
        "clock": clock,
        "heading_alignment": heading,
        "two_boot_settings": tb.to_dict(),
        "settings": settings.to_dict(),
        "timings_s": timings,
        "warnings": [f"{label}: {w}" for label in LABELS for w in single[label].warnings],
    }
    return result


def _nanmean(a) -> float:
    a = np.asarray(a, float)
    return float(np.nanmean(a)) if np.isfinite(a).any() else math.nan


def fuse_for_evaluation(left_result, right_result, settings, tb: TwoBootSettings | None = None) -> dict:
    """The fused feet of a dataset trial whose left and right foot files were processed alone (``bootnav eval``).

    Returns
    -------
    dict
        ``{"left": (t_s, pos_n, stance), "right": (...), "seconds": s, "metrics": {...}, "single_xy": {label:
        (N, 2)}, "walker_xy": (N, 2)}``: each fused foot's path for the trial's METRICS.md scoring, truth-free
        figures of the pair (the height change of each foot alone and fused, ``climb_*``: both feet of one
        walker climb the same; the constraint updates, the clock check), and for the plots each foot alone
        in the common frame and the walker (midpoint of the fused feet).
    """
    from bootnav.postproc.strides import path_summary

    t0 = time.perf_counter()
    res = fuse_results({"left": left_result, "right": right_result}, settings, tb or TwoBootSettings())
    floors, min_stride = settings.floor_settings(), settings.selftune.min_stride_m
    climb = {}
    for kind in ("single", "fused"):
        for label in LABELS:
            r = res.single[label] if kind == "single" else getattr(res.fused, label)
            stats = path_summary(r.t_s, r.pos_n, r.stance, floors, min_stride)
            climb[(kind, label)] = stats.get("height_change_m", math.nan)
    metrics = {
        "climb_single_diff_m": abs(climb[("single", "left")] - climb[("single", "right")]),
        "climb_fused_m": 0.5 * (climb[("fused", "left")] + climb[("fused", "right")]),
        "climb_fused_diff_m": abs(climb[("fused", "left")] - climb[("fused", "right")]),
        "active_updates": res.fused.n_active,
        "checks": res.fused.n_checks,
        "clock_offset_ms": 1e3 * res.clock["offset_s"],
        "clock_residual_ms": 1e3 * res.clock["residual_s"],
        "frame_yaw_deg": math.degrees(res.heading["yaw_rad"]),
        "mean_step_width_m": _nanmean(np.concatenate([res.gait[k]["step_width_m"] for k in LABELS])),
    }
    out = {label: (getattr(res.fused, label).t_s, getattr(res.fused, label).pos_n, getattr(res.fused, label).stance)
           for label in LABELS}
    out.update(seconds=time.perf_counter() - t0, metrics=metrics,
               single_xy={label: single_in_common_frame(res, label)[:, :2] for label in LABELS},
               walker_xy=res.walker_pos_n[:, :2])
    return out


def single_in_common_frame(result: TwoBootResult, label: str) -> np.ndarray:
    """A foot's single-foot path (N, 3) in the fused frame: the right one turned by the frame alignment and
    moved to its assumed start (for plots that compare a foot alone with the fused feet)."""
    p = np.asarray(result.single[label].pos_n, float)
    if label == "left":
        return p
    yaw = result.heading["yaw_rad"]
    c, s = math.cos(yaw), math.sin(yaw)
    turned = np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2]])
    return turned + getattr(result.fused, label).pos_n[0] - turned[0]
