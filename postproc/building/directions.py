"""Does this walk follow a building's axes? A truth-free decision for the dominant-direction heading aid.

In most buildings corridors are parallel or at right angles, so the headings of the strides of a walk
inside them cluster around four directions 90° apart [Borenstein2009; Borenstein2010 (HDE)]; in complex
buildings only some parts do, so the aid should act where the strides show it [Jimenez2011 (iHDE)]. The
heading aid (``ins.measurements.heading_aid``) pulls every stride that lies within a gate of that grid onto
it: right in a rectilinear building, wrong in a mocap room, an open hall or a free walk. This module decides
from the strides of a path computed WITHOUT the aid whether to switch it on.

Rule (every number in ``FilterSettings``):

1. Strides: footprint to footprint (``strides.footprints``), at least ``hde_min_stride_m`` long (the aid's own
   rule: shuffling and turning on the spot give no heading); heading ψ_k = atan2(Δy, Δx).
2. Straight strides: |ψ_k − ψ_{k−1}| and |ψ_{k+1} − ψ_k| both below ``hde_threshold_rad`` (the aid's gate):
   the stride is inside a straight leg, not in a turn.
3. Windows of ``hde_auto_window`` to twice as many consecutive straight strides (the heading drift of the
   unaided path over a window is small: ~1 min of walking; a recording with fewer straight strides is one
   window, if it has at least ``hde_auto_min_strides``: with 10 strides in random directions, a share of
   50 % on a fitted grid has a chance of about 1 %). In each window the grid direction is the 90°-periodic circular mean
   θ = arg(Σ exp(4iψ)) / 4; the window's **share** is the fraction of its strides within
   ``hde_auto_tolerance_rad`` of θ + m·90°, its **cross share** the fraction of those aligned strides on the
   axis at right angles to the one that carries most (a corridor at right angles walked at least once).
   For headings with no preferred direction the share is near 4 · 2 tol / 360° (11 % at 5°).
4. The aid is on when, over all windows together, the share is at least ``hde_auto_min_share`` AND the cross
   share at least ``hde_auto_min_cross``. An out-and-back walk lies on one axis (cross share 0): off. Its reference grid direction is that of the earliest ``EARLY_STRIDES`` aligned
   strides of the first window that passes (the unaided path's heading drifts: the earliest strides are the
   least rotated).

Per segment (``heading_aid_segments``, on by default; ``segment_flags``): once the recording is on, the aid
corrects only the strides of *straight legs along the grid* [Jimenez2011 (iHDE): the heading is only held
where the walker walks a straight line along a dominant direction]:

5. Legs: maximal runs of consecutive strides whose headings stay within ``hde_auto_tolerance_rad`` of the
   run's mean heading; a leg counts from ``hde_leg_min_strides`` strides (turns, curves, shuffles and
   isolated strides are in no leg).
6. Local grid: around each leg, the ``hde_auto_window`` leg strides nearest in time (offline: centred;
   ``bootnav live``: the latest), their grid direction θ and share as in step 3 (the unaided heading's drift
   over the recording does not matter, only over a window).
7. The leg is **aided** when that share is at least ``hde_auto_min_share`` (the walker is in a part of the
   building with a grid) and the leg's mean heading lies within ``hde_auto_tolerance_rad`` of θ + m·90°.
   Left alone: legs at 45°, legs crossing an open hall or a mocap room off the grid, curves, turns, and
   every leg in a stretch where the legs around show no grid. The filter gets a per-sample gate
   (``segment_gate``; ``run_filter(heading_gate=…)``, ``layout.HDE_GATE``) that is open over the strides
   of aided legs; elsewhere the aid keeps its memory but corrects nothing.

The summary counts the strides per outcome (``HeadingDecision.segments``).

Causal form (``CausalDirections``, ``bootnav live``): windows of ``hde_auto_window`` straight strides as they
come; after every straight stride (once the open window holds ``hde_auto_min_strides``) the full windows and
the open one are pooled; the aid switches on at the first moment they pass, and stays on. Its reference is
the direction of the earliest aligned strides of the open window. Per segment, after every stride: the
current leg (the latest strides within the tolerance of their mean) and the latest ``hde_auto_window`` leg
strides give the gate for the strides that follow (``CausalDirections.gate_open``).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import asdict, dataclass, field

import numpy as np

QUARTER = 0.5 * math.pi
EARLY_STRIDES = 10  # the reference grid direction: mean of this many earliest aligned strides (noise / sqrt(10))


def wrap(a):
    """Angle(s) wrapped to (−π, π]."""
    return np.arctan2(np.sin(a), np.cos(a))


def grid_error(psi, theta):
    """Heading(s) minus the nearest of theta + m·90°, in [−45°, 45°)."""
    e = wrap(np.asarray(psi) - theta)
    return e - np.floor(e / QUARTER + 0.5) * QUARTER


def stride_headings(fp_xy: np.ndarray, min_stride_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Headings (rad) and end-footprint indices of the strides between footprints at least ``min_stride_m``
    apart (``strides.stride_footprints``, horizontal)."""
    from bootnav.postproc.strides import stride_footprints

    fp_xy = np.asarray(fp_xy, float).reshape(-1, 2)
    if len(fp_xy) < 2:
        return np.zeros(0), np.zeros(0, int)
    keep = stride_footprints(fp_xy, min_stride_m)
    d = np.diff(fp_xy[keep], axis=0)
    return np.arctan2(d[:, 1], d[:, 0]), keep[1:]


def straight_mask(psi: np.ndarray, max_turn_rad: float) -> np.ndarray:
    """Strides whose heading differs from both neighbours' by less than ``max_turn_rad``."""
    if len(psi) < 3:
        return np.zeros(len(psi), bool)
    turn = np.abs(wrap(np.diff(psi)))
    ok = np.zeros(len(psi), bool)
    ok[1:-1] = (turn[:-1] < max_turn_rad) & (turn[1:] < max_turn_rad)
    return ok


@dataclass
class Window:
    first: int  # index of its first straight stride among all strides
    last: int
    theta_rad: float  # grid direction
    share: float  # fraction within tolerance of the grid
    cross: float  # fraction of the aligned strides on the minor axis
    n_aligned: int
    n_cross: int


def window_stats(psi: np.ndarray, tol_rad: float) -> tuple[float, float, int, int]:
    """(θ, share, n_aligned, n_cross) of one window of straight-stride headings."""
    theta = float(np.angle(np.exp(4j * psi).sum()) / 4.0)
    aligned = np.abs(grid_error(psi, theta)) < tol_rad
    axis = np.abs(wrap(2.0 * (psi[aligned] - theta))) > QUARTER  # on the axis at right angles to theta
    n_a, n_b = int(aligned.sum()), int(axis.sum())
    return theta, float(aligned.mean()), n_a, min(n_b, n_a - n_b)


@dataclass
class HeadingDecision:
    """What the rule decided and why (JSON-ready with ``as_dict``)."""

    on: bool
    reason: str
    reference_rad: float = float("nan")  # grid direction the aid uses (path frame)
    share: float = float("nan")
    cross: float = float("nan")
    n_strides: int = 0
    n_straight: int = 0
    windows: list = field(default_factory=list)
    segments: dict = field(default_factory=dict)  # per-segment outcome: strides per kind (``segment_flags``)

    def as_dict(self) -> dict:
        d = asdict(self)
        d["reference_deg"] = math.degrees(self.reference_rad) if math.isfinite(self.reference_rad) else None
        d["windows"] = [{"first_stride": w.first, "last_stride": w.last, "direction_deg": math.degrees(w.theta_rad),
                         "share": w.share, "cross": w.cross} for w in self.windows]
        return d


def decide(fp_xy: np.ndarray, settings) -> HeadingDecision:
    """The rule of the module docstring on footprints (K, ≥2) of a path computed without the aid.

    ``settings``: a ``FilterSettings`` (``hde_*`` fields)."""
    psi, _ = stride_headings(fp_xy, settings.hde_min_stride_m)
    if getattr(settings, "mode", "time_varying") == "riccati":
        return HeadingDecision(False, "off: the paper mode (filter mode 'riccati') has no yaw gain", n_strides=len(psi))
    straight = np.flatnonzero(straight_mask(psi, settings.hde_threshold_rad))
    W, n_min = int(settings.hde_auto_window), int(settings.hde_auto_min_strides)
    windows = []
    if len(straight) >= n_min:
        for idx in np.array_split(straight, max(1, len(straight) // W)):  # W to 2W - 1 strides each
            theta, share, n_a, n_c = window_stats(psi[idx], settings.hde_auto_tolerance_rad)
            windows.append(Window(int(idx[0]), int(idx[-1]), theta, share, n_c / max(n_a, 1), n_a, n_c))
    base = dict(n_strides=len(psi), n_straight=len(straight), windows=windows)
    if not windows:
        return HeadingDecision(False, f"too few straight strides ({len(straight)} < {n_min}) to see a building's "
                               "axes", **base)
    n_a = sum(w.n_aligned for w in windows)
    share = n_a / len(straight)
    cross = sum(w.n_cross for w in windows) / max(n_a, 1)
    ok_share, ok_cross = share >= settings.hde_auto_min_share, cross >= settings.hde_auto_min_cross
    first = next((w for w in windows if w.share >= settings.hde_auto_min_share), windows[0])
    # the reference: the earliest aligned strides of that window (the unaided heading drifts with time)
    idx = straight[(straight >= first.first) & (straight <= first.last)]
    early = idx[np.abs(grid_error(psi[idx], first.theta_rad)) < settings.hde_auto_tolerance_rad][:EARLY_STRIDES]
    reference = float(np.angle(np.exp(4j * psi[early]).sum()) / 4.0) if early.size else first.theta_rad
    tol = math.degrees(settings.hde_auto_tolerance_rad)
    why = (f"{share:.0%} of {len(straight)} straight strides within {tol:.0f} deg of a 90-deg grid (need "
           f"{settings.hde_auto_min_share:.0%}), {cross:.0%} of them at right angles to the main axis (need "
           f"{settings.hde_auto_min_cross:.0%})")
    on = bool(ok_share and ok_cross)
    reason = ("on: " if on else "off: ") + why
    return HeadingDecision(on, reason, reference if on else float("nan"), share, cross, **base)


class CausalDirections:
    """The rule on the strides seen so far (``bootnav live``): push footprints as they become final; ``on``
    turns True (and stays) the first time the pooled windows pass; ``reference_rad`` is then the direction of
    the latest window (the current frame of the path, whatever it drifted before)."""

    def __init__(self, settings):
        self.s = settings
        self._last_xy = None  # last kept footprint
        self._psi: list[float] = []  # headings of the kept strides
        self._straight_idx: list[int] = []
        self._n_aligned = self._n_cross = self._n_windows = 0
        self.on = False
        self.reference_rad = float("nan")
        self.decided_at_stride = -1
        # per segment (steps 5-7): the current leg (sum of unit vectors, its headings), the latest leg strides
        self._leg_c = 0j
        self._leg: list[float] = []  # its first hde_leg_min_strides headings (bounded)
        self._leg_n = 0
        self._leg_window: deque = deque(maxlen=int(settings.hde_auto_window))
        self.gate_open = False  # the aid may correct the strides that follow
        self.segments = {k: 0 for k in SEGMENT_KINDS}  # strides per outcome, as decided when each came

    def push(self, fp_xy: np.ndarray) -> bool:
        """Add footprints (K, 2); returns True when this call switched the aid on (it then stays on).
        ``gate_open`` is then the per-segment gate for the strides that follow."""
        switched = False
        for xy in np.asarray(fp_xy, float).reshape(-1, 2):
            if self._last_xy is None:
                self._last_xy = xy
                continue
            d = xy - self._last_xy
            if math.hypot(*d) < self.s.hde_min_stride_m:
                continue
            self._last_xy = xy
            psi = math.atan2(d[1], d[0])
            self._segment(psi)
            if not self.on and self._decide(psi):
                switched = True
        return switched

    def _segment(self, psi: float) -> None:
        """Steps 5-7 causally: extend or restart the current leg; the gate for the strides that follow."""
        s = self.s
        c = self._leg_c
        n_min = int(s.hde_leg_min_strides)
        if self._leg_n and abs(math.remainder(psi - math.atan2(c.imag, c.real), 2.0 * math.pi)) >= \
                s.hde_auto_tolerance_rad:
            self._leg, self._leg_c, self._leg_n = [], 0j, 0
        self._leg_n += 1
        self._leg_c += complex(math.cos(psi), math.sin(psi))
        if self._leg_n <= n_min:
            self._leg.append(psi)
        if self._leg_n == n_min:
            self._leg_window.extend(self._leg)
        elif self._leg_n > n_min:
            self._leg_window.append(psi)
        if self._leg_n < n_min:
            kind = "not in a straight leg"
        else:
            kind = leg_kind(math.atan2(self._leg_c.imag, self._leg_c.real), np.fromiter(self._leg_window, float),
                            s)
        self.segments[kind] += 1
        self.gate_open = kind == "aided"

    def _decide(self, psi: float) -> bool:
        """Steps 1-4 on the strides so far; True when they pass for the first time."""
        s, W = self.s, int(self.s.hde_auto_window)
        self._psi.append(psi)
        p = self._psi
        if len(p) >= 3 and abs(wrap(p[-2] - p[-3])) < s.hde_threshold_rad and \
                abs(wrap(p[-1] - p[-2])) < s.hde_threshold_rad:
            self._straight_idx.append(len(p) - 2)
            n = len(self._straight_idx)
            cur = n - W * self._n_windows  # strides in the open window
            if cur < s.hde_auto_min_strides:
                return False
            win = np.asarray(p)[self._straight_idx[W * self._n_windows:]]
            theta, _, n_a, n_c = window_stats(win, s.hde_auto_tolerance_rad)
            if self._pass(self._n_aligned + n_a, self._n_cross + n_c, n):
                early = win[np.abs(grid_error(win, theta)) < s.hde_auto_tolerance_rad][:EARLY_STRIDES]
                self.on, self.decided_at_stride = True, len(p)
                self.reference_rad = float(np.angle(np.exp(4j * early).sum()) / 4.0) if early.size else theta
                self._psi = []  # decided: the strides' headings are not needed any more
                return True
            if cur == W:  # the window is full: its figures join the pooled ones
                self._n_aligned += n_a
                self._n_cross += n_c
                self._n_windows += 1
        return False

    def _pass(self, n_aligned: int, n_cross: int, n_straight: int) -> bool:
        s = self.s
        return (n_aligned / n_straight >= s.hde_auto_min_share
                and n_cross / max(n_aligned, 1) >= s.hde_auto_min_cross)


# ---------------------------------------------------------------------------------------------------------------
# per segment (steps 5-7 of the module docstring)

SEGMENT_KINDS = ("aided", "leg off the grid", "no grid around", "not in a straight leg")


def legs(psi: np.ndarray, tol_rad: float) -> list[tuple[int, int, float]]:
    """Maximal runs of consecutive strides within ``tol_rad`` of the run's running mean heading:
    ``(first, stop, mean heading)`` (stop exclusive). One Python iteration per stride."""
    out = []
    n, j = len(psi), 0
    while j < n:
        c = complex(math.cos(psi[j]), math.sin(psi[j]))
        k = j + 1
        while k < n and abs(math.remainder(psi[k] - math.atan2(c.imag, c.real), 2.0 * math.pi)) < tol_rad:
            c += complex(math.cos(psi[k]), math.sin(psi[k]))
            k += 1
        out.append((j, k, math.atan2(c.imag, c.real)))
        j = k
    return out


def leg_kind(leg_heading_rad: float, window_psi: np.ndarray, settings) -> str:
    """Step 7 for one leg of at least ``hde_leg_min_strides`` strides: ``"aided"``, ``"no grid around"``
    (the leg strides around it show no grid) or ``"leg off the grid"``."""
    if len(window_psi) < settings.hde_auto_min_strides:
        return "no grid around"
    theta, share, _, _ = window_stats(np.asarray(window_psi, float), settings.hde_auto_tolerance_rad)
    if share < settings.hde_auto_min_share:
        return "no grid around"
    if abs(float(grid_error(leg_heading_rad, theta))) >= settings.hde_auto_tolerance_rad:
        return "leg off the grid"
    return "aided"


def segment_flags(psi: np.ndarray, settings) -> tuple[np.ndarray, dict]:
    """Steps 5-7 offline on the stride headings ``psi`` of the unaided path: (aided (M,) bool per stride,
    strides per outcome ``SEGMENT_KINDS``)."""
    psi = np.asarray(psi, float)
    tol, n_min, W = settings.hde_auto_tolerance_rad, int(settings.hde_leg_min_strides), int(settings.hde_auto_window)
    kind = np.full(len(psi), SEGMENT_KINDS.index("not in a straight leg"), dtype=np.int64)
    found = [(a, b, h) for a, b, h in legs(psi, tol) if b - a >= n_min]
    in_leg = np.concatenate([np.arange(a, b) for a, b, _ in found]) if found else np.zeros(0, np.int64)
    rank = np.searchsorted(in_leg, np.arange(len(psi)))  # rank of a leg stride among the leg strides
    for a, b, h in found:
        centre = (int(rank[a]) + int(rank[b - 1])) // 2
        lo = max(0, min(centre - W // 2, len(in_leg) - W))
        kind[a:b] = SEGMENT_KINDS.index(leg_kind(h, psi[in_leg[lo:lo + W]], settings))
    counts = {k: int((kind == i).sum()) for i, k in enumerate(SEGMENT_KINDS)}
    counts["legs"] = len(found)
    counts["aided_legs"] = sum(1 for a, _, _ in found if kind[a] == 0)
    return kind == 0, counts


def gate_intervals(phase_stops: np.ndarray, stride_end_fp: np.ndarray, aided: np.ndarray) -> np.ndarray:
    """The aid's gate (``segment_gate``) as sample intervals: (J, 2) int64 rows [first, stop) where it is open,
    sorted and disjoint (bounded memory for a long recording: one row per run of aided strides).

    ``phase_stops``: the stop index (exclusive) of every stance phase (``core.runs.runs``' stops); stance phase
    p's stride is open from the end of phase p − 1 (sample 0 for p = 0) to the end of phase p."""
    stops = np.asarray(phase_stops, np.int64)
    p = np.unique(np.asarray(stride_end_fp, np.int64)[np.asarray(aided, bool)])
    if p.size == 0:
        return np.zeros((0, 2), np.int64)
    lo = np.where(p > 0, stops[np.maximum(p - 1, 0)], 0)
    hi = stops[p]
    new = np.concatenate(([True], p[1:] != p[:-1] + 1))  # a run of consecutive open phases is one interval
    last = np.concatenate((np.flatnonzero(new)[1:] - 1, [p.size - 1]))
    return np.column_stack((lo[new], hi[last]))


def gate_of(intervals: np.ndarray, i0: int, i1: int) -> np.ndarray:
    """The per-sample gate of samples i0..i1−1 from ``gate_intervals``' rows."""
    idx = np.arange(i0, i1, dtype=np.int64)
    iv = np.asarray(intervals, np.int64).reshape(-1, 2)
    k = np.searchsorted(iv[:, 0], idx, side="right") - 1
    return (k >= 0) & (idx < iv[np.maximum(k, 0), 1]) if len(iv) else np.zeros(len(idx), bool)


def segment_gate(n_samples: int, stance: np.ndarray, stride_end_fp: np.ndarray, aided: np.ndarray) -> np.ndarray:
    """Per-sample gate of the aid: open over the swing and stance phase of every aided stride (from the end of
    the stance phase before to the end of the one the stride ends in), so that the aid's measurement at that
    stance onset (delayed or not) sees it open. ``stride_end_fp``: index of the stance phase (footprint) each
    stride ends in (``stride_headings``)."""
    from bootnav.core.runs import runs

    _, stops = runs(np.asarray(stance, bool))
    return gate_of(gate_intervals(stops, stride_end_fp, aided), 0, n_samples)


def heading_plan(fp_xy: np.ndarray, settings) -> tuple[HeadingDecision, np.ndarray | None, np.ndarray | None]:
    """The heading decision (``heading_aid="auto"``) on the footprints (K, 2) of the unaided path: (decision, index of the
    footprint each stride ends in, aided flag per stride); both None when the aid is off or acts on every
    stride (``heading_aid_segments`` off). The decision's reason names the per-segment counts."""
    dec = decide(fp_xy, settings)
    if not (dec.on and settings.heading_aid_segments):
        return dec, None, None
    psi, ends = stride_headings(fp_xy, settings.hde_min_stride_m)
    aided, dec.segments = segment_flags(psi, settings)
    dec.reason += (f"; per segment: {dec.segments['aided']} of {len(psi)} strides in "
                   f"{dec.segments['aided_legs']} straight legs along the grid aided, "
                   f"{dec.segments['leg off the grid']} in legs off the grid, "
                   f"{dec.segments['no grid around']} where the strides around show no grid, "
                   f"{dec.segments['not in a straight leg']} in turns, curves or short moves")
    return dec, ends, aided


def aided_settings(settings, dec: HeadingDecision):
    """The filter settings of the aided run: the aid on at the decided grid direction."""
    from dataclasses import replace

    return replace(settings, heading_aid="dominant_directions", heading_aid_reference_rad=dec.reference_rad)
