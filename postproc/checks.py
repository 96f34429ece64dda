"""Plausibility checks of ``process``: bad input becomes a clear message, never a garbage path.

Two kinds, with the limits in ``settings.InputChecks``:

* **Unprocessable input** (``check_samples``, ``check_path_finite``): NaN/inf, time going backwards, too
  short, a gap the strapdown integration cannot bridge, a diverged filter. Nothing sensible can be computed,
  so these raise ``InputError`` at once, naming the sample index and time.
* **Implausible results** (``stance_findings``, ``stride_findings``): a stance mask or strides that a
  walking foot cannot produce. These *return* ``Finding`` objects; the caller decides what to do with them.
  ``refuse_fatal`` is today's policy in ``process``: raise on the first fatal finding, keep the others as
  warnings.

Saturation is reported, not refused: ``saturation_intervals`` lists the bursts at full scale (from the
recording's bitmask, plus ``clipping_bits`` for inputs without one) and ``saturation_warnings`` turns them
into one line.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.core.runs import runs
from bootnav.core.timebase import GAP_FACTOR, gap_mask, nominal_period
from bootnav.errors import InputError
from bootnav.logger.recording import SATURATION_BITS

from bootnav.core.arrays import row_norm, rows_finite
from .settings import InputChecks

AXIS_NAMES = {v: k for k, v in SATURATION_BITS.items()}  # bit -> "ax", ...
_STANCE_HINT = ("check that the sensor is on the foot (not waist or hand: use `bootnav pdr`), or choose another "
                "detector / threshold (--detector, --settings)")


@dataclass(frozen=True)
class Finding:
    """One implausibility found by a check."""

    check: str  # which check: "stance_gyro", "single_rest", "few_stance_phases", "stance_fraction", "long_strides"
    message: str  # one line, without the input's name
    fatal: bool  # True: by today's policy the path would be garbage (``refuse_fatal`` raises)


def refuse_fatal(name: str, findings: list[Finding]) -> list[str]:
    """Today's policy: raise on the first fatal finding, return the others' messages as warnings.

    Parameters
    ----------
    name
        How the error message names the input.
    findings
        From ``stance_findings`` or ``stride_findings``.

    Returns
    -------
    list of str
        The messages of the non-fatal findings.

    Raises
    ------
    InputError
        ``"<name>: <message>"`` of the first fatal finding.
    """
    for f in findings:
        if f.fatal:
            raise InputError(f"{name}: {f.message}")
    return [f.message for f in findings]


def check_samples(name: str, t_s: np.ndarray, acc_b: np.ndarray, gyro_b: np.ndarray, offset: int,
                  checks: InputChecks, record_span: tuple[float, float] | None = None) -> list[str]:
    """Refuse samples that cannot be integrated; report what is only suspicious.

    Parameters
    ----------
    name
        How messages name the input.
    t_s, acc_b, gyro_b
        (N,) s, (N, 3) m/s^2, (N, 3) rad/s: the processed window.
    offset
        Index of the window's first sample in the recording (messages give recording sample indices).
    checks
        The limits.
    record_span
        The first and last time of the whole window when ``t_s`` is one block of it (the passes over blocks):
        its duration is the one checked and the crops a gap suggests end there; None: ``t_s``'s own.

    Returns
    -------
    list of str
        Warnings: short gaps (integrated over with the real time step) and duplicate timestamps.

    Raises
    ------
    InputError
        Fewer than 3 samples, no gyroscope, NaN/inf, time going backwards, shorter than
        ``checks.min_duration_s``, or a gap longer than ``checks.max_gap_s``.
    """
    n = len(t_s)
    if n < 3:
        raise InputError(f"{name}: only {n} samples; nothing to process")
    if np.all(np.isnan(gyro_b)):
        raise InputError(f"{name}: no gyroscope data (accelerometer-only file): foot-mounted ZUPT navigation "
                         "needs a gyro; use `bootnav pdr` for step-and-heading dead reckoning")
    finite = np.isfinite(t_s) & rows_finite(acc_b) & rows_finite(gyro_b)
    if not finite.all():
        i = int(np.flatnonzero(~finite)[0])
        cols = [c for c, v in zip(("t_s", "ax", "ay", "az", "gx", "gy", "gz"),
                                   np.concatenate(([t_s[i]], acc_b[i], gyro_b[i]))) if not np.isfinite(v)]
        t_txt = f"t = {t_s[i]:.4f} s" if np.isfinite(t_s[i]) else "time unknown"
        raise InputError(f"{name}: sample {i + offset} ({t_txt}): NaN/inf in {', '.join(cols)} "
                         f"({int((~finite).sum())} bad samples in all); crop around them with --crop T0 T1")
    dt = np.diff(t_s)
    back = np.flatnonzero(dt < 0)
    if len(back):
        i = int(back[0]) + 1
        raise InputError(f"{name}: sample {i + offset}: time goes backwards ({t_s[i - 1]:.6f} s -> {t_s[i]:.6f} s); "
                         "re-import the file (`bootnav import` repairs device-clock wraps)")
    t_first, t_last = (float(t_s[0]), float(t_s[-1])) if record_span is None else record_span
    duration = t_last - t_first
    if duration < checks.min_duration_s:
        raise InputError(f"{name}: too short: {duration:.2f} s of data (need >= {checks.min_duration_s:g} s: "
                         "a still period plus a few strides)")
    warnings = []
    med = nominal_period(dt)
    big = np.flatnonzero(dt > checks.max_gap_s)
    if len(big):
        i = int(big[0])
        # suggest only the sides long enough to process (never a zero-length crop)
        sides = [f"--crop {a:.3f} {b:.3f}" for a, b in ((t_first, t_s[i]), (t_s[i + 1], t_last))
                 if b - a >= checks.min_duration_s]
        how = (f"process {'each side' if len(sides) == 2 else 'the part after or before it'} with "
               + " / ".join(sides) if sides else "neither side is long enough to process; are the times in seconds?")
        raise InputError(f"{name}: sample {i + 1 + offset}: gap of {dt[i]:.3f} s at t = {t_s[i]:.3f} s "
                         f"(> {checks.max_gap_s:g} s cannot be bridged by integration); {how}")
    steps = StepWarnings(med)
    steps.push(t_s[:-1], dt)
    return warnings + steps.warnings()


class StepWarnings:
    """``check_samples``' warnings on the time steps (short gaps, duplicate timestamps) of a record whose steps
    are pushed in consecutive pieces; ``med``: the record's nominal period (``timebase.nominal_period``), s."""

    def __init__(self, med: float):
        self.med = med
        self.n_gaps = self.n_dup = 0
        self.longest_s, self.t_longest_s = -np.inf, np.nan

    def push(self, t_start_s: np.ndarray, dt: np.ndarray) -> None:
        """Steps ``dt`` (s) starting at the times ``t_start_s`` (s), after every step pushed before."""
        gaps = np.flatnonzero(gap_mask(dt, self.med))
        if len(gaps):
            self.n_gaps += len(gaps)
            k = gaps[np.argmax(dt[gaps])]
            if dt[k] > self.longest_s:  # the first of the longest, as np.argmax over the record
                self.longest_s, self.t_longest_s = float(dt[k]), float(t_start_s[k])
        self.n_dup += int((dt == 0).sum())

    def warnings(self) -> list[str]:
        out = []
        if self.n_gaps:
            out.append(f"{self.n_gaps} gaps longer than {GAP_FACTOR:g} x the median interval "
                       f"({self.med * 1e3:.2f} ms), longest {self.longest_s * 1e3:.1f} ms at t = {self.t_longest_s:.3f} s "
                       "(integrated over with the real time step)")
        if self.n_dup:
            out.append(f"{self.n_dup} duplicate timestamps (zero time step; integrated as no time elapsed)")
        return out


def clipping_bits(acc_b: np.ndarray, gyro_b: np.ndarray, sloping: bool = False) -> np.ndarray:
    """Saturation bitmask (bits as the recording's) from full-scale plateaus, for inputs without a mask.

    Parameters
    ----------
    acc_b, gyro_b
        (N, 3) m/s^2 and rad/s.

    Returns
    -------
    ndarray of uint8, shape (N,)
        Bit ``SATURATION_BITS[axis]`` set where that axis sits on a rail
        (``bootnav.core.arrays.clipped_axes``; with ``sloping``, also the rails that a calibrated output makes
        slope on a gyro axis without an exact one, ``bootnav.core.arrays.sloping_rails``).
    """
    from bootnav.core.arrays import clipped_axes

    bits = np.zeros(len(acc_b), dtype=np.uint8)
    exact = clipped_axes(gyro_b)
    for first, axes in ((0, clipped_axes(acc_b)), (3, exact)):
        for k, mask in axes.items():
            bits |= mask.astype(np.uint8) << (first + k)
    return bits | sloping_gyro_bits(gyro_b, exact) if sloping else bits


def sloping_gyro_bits(gyro_b: np.ndarray, exact: dict) -> np.ndarray:
    """Saturation bits (as ``clipping_bits``') of the gyro rails that a calibrated output makes slope
    (``bootnav.core.arrays.sloping_rails``), on the axes whose exact rails (``exact``: {axis: mask}) do not
    already explain them."""
    from bootnav.core.arrays import GYRO_MIN_FULL_SCALE_RADPS, sloping_rails

    bits = np.zeros(len(gyro_b), dtype=np.uint8)
    # a rail that repeats one value holds most of its plateau samples at it, and the samples just below are
    # real values; a sloping rail may repeat its top by chance (quantised cross-axis terms), not most of it
    for k, m in sloping_rails(gyro_b, GYRO_MIN_FULL_SCALE_RADPS).items():
        if k not in exact or 2 * np.count_nonzero(exact[k] & m) < np.count_nonzero(m):
            bits |= m.astype(np.uint8) << (3 + k)
    return bits


def saturation_intervals(t_s: np.ndarray, saturated: np.ndarray, offset: int = 0) -> list[dict]:
    """Contiguous bursts of saturated samples with the axes involved.

    Parameters
    ----------
    t_s
        (N,) s.
    saturated
        (N,) uint8 bitmask (bits ``SATURATION_BITS``), or (N, k) bool (axes then unknown).
    offset
        Index of ``t_s[0]`` in the recording.

    Returns
    -------
    list of dict
        One per burst: ``t0_s``, ``t1_s`` (first and last saturated sample), ``i0``, ``i1`` (their recording
        indices, inclusive), ``samples``, ``axes`` (names "ax".."gz").
    """
    sat = np.asarray(saturated)
    mask = sat.astype(bool) if sat.ndim == 1 else sat.any(axis=1)
    out = []
    for a, b in zip(*runs(mask)):  # one iteration per burst, not per sample
        bits = int(np.bitwise_or.reduce(sat[a:b].astype(np.uint8))) if sat.ndim == 1 else 0
        axes = [AXIS_NAMES[k] for k in range(6) if bits >> k & 1]
        out.append({"t0_s": float(t_s[a]), "t1_s": float(t_s[b - 1]), "i0": int(a + offset),
                    "i1": int(b - 1 + offset), "samples": int(b - a), "axes": axes})
    return out


def join_saturation_intervals(before: list[dict], after: list[dict]) -> list[dict]:
    """The bursts of two consecutive pieces of a record (``saturation_intervals`` of each): a burst running
    across the boundary is one, as ``saturation_intervals`` of the whole gives it."""
    if before and after and after[0]["i0"] == before[-1]["i1"] + 1:
        a, b = before[-1], after[0]
        axes = [AXIS_NAMES[k] for k in range(6) if AXIS_NAMES[k] in a["axes"] + b["axes"]]
        joined = {**a, "t1_s": b["t1_s"], "i1": b["i1"], "samples": a["samples"] + b["samples"], "axes": axes}
        return before[:-1] + [joined] + after[1:]
    return before + after


def saturation_warnings(intervals: list[dict]) -> list[str]:
    """One warning line for the bursts of ``saturation_intervals`` (none when there are none)."""
    if not intervals:
        return []
    n_sat = sum(iv["samples"] for iv in intervals)
    worst = max(intervals, key=lambda iv: iv["samples"])
    return [f"{len(intervals)} saturated bursts ({n_sat} samples at full scale, longest "
            f"{worst['t0_s']:.3f}-{worst['t1_s']:.3f} s on {'/'.join(worst['axes']) or 'unknown axes'}): "
            "the path is less trustworthy there (intervals listed in summary.json)"]


def stance_findings(t_s: np.ndarray, stance: np.ndarray, checks: InputChecks, method: str,
                    gyro_b: np.ndarray | None = None) -> list[Finding]:
    """What makes a stance mask implausible for a walking foot (see ``InputChecks``).

    Parameters
    ----------
    t_s
        (N,) s.
    stance
        (N,) bool, True = foot at rest.
    checks
        The limits.
    method
        The detector's name (for the messages).
    gyro_b
        (N, 3) rad/s; with it, "stance" turning faster than a resting foot can is found too.

    Returns
    -------
    list of Finding
        In order of diagnostic value (the first explains the most); all fatal today. Empty: plausible.
    """
    w = float(np.median(row_norm(gyro_b[stance]))) if gyro_b is not None and stance.any() else None
    return stance_findings_of(len(runs(stance)[0]), float(np.mean(stance)), float(t_s[-1] - t_s[0]), w, checks,
                              method)


def stance_findings_of(n_phases: int, frac: float, span: float, w: float | None, checks: InputChecks,
                       method: str) -> list[Finding]:
    """``stance_findings`` from its figures: stance phases, fraction of samples at rest, the record's span (s) and
    the median angular rate over the stance samples (rad/s; None: not checked). The one definition of the
    findings: a recording read in blocks gives the figures from a pass over them (``passes.BlockPasses``)."""
    found = []
    if w is not None:
        if w > checks.max_stance_gyro_radps:
            found.append(Finding("stance_gyro", f"stance detector '{method}' marks {100 * frac:.0f} % of samples as "
                                 f"stance, but the sensor turns at a median {w:.2f} rad/s there (a resting foot: < "
                                 f"{checks.max_stance_gyro_radps:g} rad/s): no zero-velocity phase found; "
                                 f"{_STANCE_HINT}", True))
    if n_phases <= 1 and frac > 0.9:
        found.append(Finding("single_rest", f"the foot is at rest for {100 * frac:.0f} % of the {span:.1f} s "
                             f"(detector '{method}': {n_phases} stance phase, no stride): nothing to navigate", True))
    if n_phases < checks.min_stance_phases:
        found.append(Finding("few_stance_phases", f"stance detector '{method}' found {n_phases} stance phase(s) in "
                             f"{span:.1f} s (need >= {checks.min_stance_phases} for zero-velocity updates); "
                             f"{_STANCE_HINT}", True))
    if not checks.min_stance_fraction <= frac <= checks.max_stance_fraction:
        found.append(Finding("stance_fraction", f"stance detector '{method}' marks {100 * frac:.1f} % of samples as "
                             f"stance (plausible {100 * checks.min_stance_fraction:.0f}-"
                             f"{100 * checks.max_stance_fraction:.0f} %); {_STANCE_HINT}", True))
    return found


def stride_findings(steps: dict, checks: InputChecks, method: str) -> list[Finding]:
    """Strides longer than a foot can move: stance phases were missed and the path between is unaided drift.

    Parameters
    ----------
    steps
        One row per stride (``strides.segment_strides``).
    checks
        The limits: ``max_stride_length_m`` (3-D), ``max_long_stride_fraction``.
    method
        The detector's name (for the message).

    Returns
    -------
    list of Finding
        At most one ("long_strides"), fatal when more than ``max_long_stride_fraction`` of the strides are long.
    """
    length = steps["stride_length_m"]
    dist3 = np.hypot(length, steps["dz_m"])
    long = np.flatnonzero(dist3 > checks.max_stride_length_m)
    if len(long) == 0:
        return []
    worst = int(long[np.argmax(dist3[long])])
    where = f"worst {dist3[worst]:.1f} m ending at t = {steps['t_s'][worst]:.2f} s"
    if len(long) > checks.max_long_stride_fraction * len(length):
        return [Finding("long_strides", f"{len(long)} of {len(length)} strides are longer than "
                        f"{checks.max_stride_length_m:g} m ({where}): the stance detector '{method}' misses stance "
                        "phases (running? sensor not on the foot?), so the path in between is unaided drift; try "
                        "another detector (--detector shoe --threshold ...) or check the mounting", True)]
    return [Finding("long_strides", f"{len(long)} strides longer than {checks.max_stride_length_m:g} m ({where}): "
                    "stance phases were probably missed there; the path is unaided drift in those intervals", False)]


def check_path_finite(name: str, t_s: np.ndarray, pos_n: np.ndarray, offset: int) -> None:
    """Refuse a diverged filter output (NaN/inf position), naming the first bad sample.

    Raises
    ------
    InputError
        At the first sample whose position is not finite (index in the recording, time).
    """
    bad = np.flatnonzero(~rows_finite(pos_n))
    if len(bad):
        raise InputError(f"{name}: the filter diverged at sample {bad[0] + offset} (t = {t_s[bad[0]]:.3f} s); "
                         "check the sensor ranges and the input units")


class ClipRails:
    """``clipping_bits`` of a recording read in blocks: two cheap passes before the bits are known.

    ``clipped_samples`` compares every sample with the per-axis extremes of the whole record and counts the
    samples at them; here ``add_peaks`` (first pass) and ``add_counts`` (second pass) see every block, and
    ``bits`` then gives exactly ``clipping_bits`` for any block. With ``sloping`` (``filter.sloping_rails``) the
    sloping gyro rails are found within each block (``sloping_gyro_bits``: a rail shows on many swings of one
    block), so a recording of one block gets exactly ``clipping_bits(..., sloping=True)``.
    """

    REL_TOL = 1e-6  # clipped_samples' defaults
    MIN_REPEATS = 3

    def __init__(self, sloping: bool = False):
        self.sloping = sloping
        self._slope_key: tuple | None = None  # the block whose sloping bits are kept (the passes read it again)
        self._slope_bits = None
        self.pos = np.full(6, -np.inf)  # max of x per axis (acc x/y/z, gyro x/y/z)
        self.neg = np.full(6, -np.inf)  # max of -x
        self.count_pos = np.zeros(6, np.int64)
        self.count_neg = np.zeros(6, np.int64)
        self.n = 0
        self.rail_pos = self.rail_neg = None

    def add_peaks(self, acc_b: np.ndarray, gyro_b: np.ndarray) -> None:
        x = np.hstack((acc_b, gyro_b))
        with np.errstate(invalid="ignore"):
            self.pos = np.fmax(self.pos, np.nanmax(x, axis=0, initial=-np.inf))
            self.neg = np.fmax(self.neg, np.nanmax(-x, axis=0, initial=-np.inf))

    def _at(self, acc_b, gyro_b):
        x = np.hstack((acc_b, gyro_b))
        return x >= self.pos * (1.0 - self.REL_TOL), -x >= self.neg * (1.0 - self.REL_TOL)

    def add_counts(self, acc_b: np.ndarray, gyro_b: np.ndarray) -> None:
        p, q = self._at(acc_b, gyro_b)
        self.count_pos += p.sum(axis=0)
        self.count_neg += q.sum(axis=0)
        self.n += len(acc_b)

    def finish(self) -> None:
        def rail(count, peak, other):
            return (count >= self.MIN_REPEATS) & (count < 0.5 * self.n) & (peak > 0) & (peak >= other * (1.0 - 1e-3))

        self.rail_pos = rail(self.count_pos, self.pos, self.neg)
        self.rail_neg = rail(self.count_neg, self.neg, self.pos)

    def bits(self, acc_b: np.ndarray, gyro_b: np.ndarray) -> np.ndarray:
        """Saturation bitmask (bits as ``clipping_bits``') of one block."""
        p, q = self._at(acc_b, gyro_b)
        on = (p & self.rail_pos) | (q & self.rail_neg)
        bits = (on.astype(np.uint8) << np.arange(6, dtype=np.uint8)).sum(axis=1, dtype=np.uint8)
        if not self.sloping or len(gyro_b) == 0:
            return bits
        key = (len(gyro_b), gyro_b[0].tobytes(), gyro_b[-1].tobytes(), gyro_b[len(gyro_b) // 2].tobytes())
        if key != self._slope_key:
            exact = {k: on[:, 3 + k] for k in range(3) if on[:, 3 + k].any()}
            self._slope_key, self._slope_bits = key, sloping_gyro_bits(gyro_b, exact)
        return bits | self._slope_bits
