"""Plausibility checks of declared units, and saturation flags.

**Gravity check.** At rest an accelerometer reads |f| = g = 9.80665 m/s². We take the *quietest second*
(the 1-s window whose |acc| has the smallest standard deviation) and its median |acc| after applying the
declared unit. If it is not within ±25 % of g, the declared unit (or range) is wrong; the error message
says which unit *would* fit: |acc| ≈ 1 means g, ≈ 9.81 means m/s², ≈ 32768/R means int16 counts at ±R g.
(±25 % tolerates a sensor tilted while moving slowly, and still separates a range off by 2x.) A recording
that never rests for a second (a foot cut out of a walk, a run) has no quiet second: when the quietest
second does not fit, the quietest ``FOOT_FLAT_S`` (0.1 s, a walking foot-flat) window is judged too, and a
declared unit that fits there passes, so a foot in motion is judged by its stance phases.

**Gyro check.** Walking feet turn at up to ~10-15 rad/s (about 600-900 °/s); the MPU6050 tops out at
2000 °/s = 34.9 rad/s. A 99.9th-percentile |ω| above 35 rad/s after conversion is physically absurd and
almost always deg/s declared as rad/s (x57.3); the error suggests ``--gyro-unit dps``.

**Gyro too small.** rad/s data declared as deg/s is 57.3x too small. The evidence is taken while the sensor
demonstrably moves: the samples whose |f| differs from g by more than 3 m/s² (0.3 g: far above noise and any slow
tilt), at least 1 s of them. While a foot accelerates like that it also rotates: its swing peaks at 5-15 rad/s, a
waist or a hand at 1-3 rad/s. The 99th percentile of |ω| over those samples is 0.77-24 rad/s on the developer
recordings (lowest: a lower-back sensor); rad/s read as deg/s turns a 15 rad/s swing into 0.26 rad/s. Below
0.3 rad/s with the unit declared deg/s the mismatch is unambiguous: an error suggesting ``--gyro-unit radps``.
Between 0.3 and 0.6 rad/s with deg/s declared it is borderline: a warning, a ``note`` event and the figure in
the metadata (``unit_check``). With rad/s or counts declared a small gyro is no unit mismatch (no flag makes it
larger by 57x) and is left alone.

**Borderline gravity.** A quietest-second |f| off g by 10-25 % passes, with the same warning/metadata: a good
sensor at rest is within 2 % of g, so such a value suggests a wrong range or a recording with no still second.

**Saturation.** A sample is saturated on an axis when its raw value is at full scale: for int16 counts
≥ 32767 or ≤ -32768; for values in physical units |v| ≥ (1 - 0.5 %) · range (the margin absorbs the
rounding of printed values, e.g. 19.62 for 2 g). Bits as in ``bootnav.logger.recording.SATURATION_BITS``;
one ``saturation`` event per run of consecutive saturated samples per axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.core.runs import runs
from bootnav.logger.mpu6050 import STANDARD_GRAVITY

ACC_TOLERANCE = 0.25
ACC_BORDERLINE = 0.10  # |f|/g off by more than this (but within ACC_TOLERANCE): a warning
GYRO_ABSURD_RADPS = 35.0
DYNAMIC_ACC_MPS2 = 3.0  # ||f| - g| above this: the sensor accelerates (0.3 g, far above noise and slow tilts)
MIN_DYNAMIC_S = 1.0  # dynamic time needed before the gyro is judged (a few strides)
GYRO_MOVING_MIN_RADPS = 0.6  # p99 |rate| while accelerating: a walking foot, waist or hand turns faster
GYRO_UNIT_ERROR_RADPS = 0.3  # below it with deg/s declared: rad/s read as deg/s (15 rad/s -> 0.26)
SI_MARGIN = 0.005
FOOT_FLAT_S = 0.1  # s, the shortest rest of a walking foot (foot-flat 0.1-0.4 s [Perry2010])
TIME_STEP_MAX_S = 0.5  # a median time step above this is no IMU in seconds (< 2 Hz): ms or us


@dataclass(frozen=True)
class Words:
    """How a unit check names the remedy: ``bootnav import``'s flags (``CLI_WORDS``) or the Python API's keywords
    (``API_WORDS``, ``bootnav.api``). The physics and thresholds are the same for both; only the words differ.
    ``acc``/``gyro``/``time`` format a unit name; ``acc_counts`` a range (None: counts are not offered);
    ``trust`` is the way to keep the data as declared; ``data`` names where the values come from; ``acc_check``
    what to check when gravity is borderline."""

    acc: str
    gyro: str
    time: str
    acc_counts: str | None
    gyro_range: str
    trust: str
    data: str
    acc_check: str


CLI_WORDS = Words(acc="--acc-unit {}", gyro="--gyro-unit {}", time="--time-unit {}",
                  acc_counts="--acc-unit counts --acc-range {}", gyro_range="check --gyro-range",
                  trust="--trust-units", data="in the file",
                  acc_check="--acc-unit and --acc-range")
API_WORDS = Words(acc='acc_unit="{}"', gyro='gyro_unit="{}"', time='time_unit="{}"', acc_counts=None,
                  gyro_range='gyro_unit="dps"', trust="check_units=False", data="in the array",
                  acc_check="the accelerometer's unit (acc_unit)")


def guess_time_unit(t_raw: np.ndarray) -> tuple[str, float]:
    """The time unit of a clock column from its median positive step: ``"s"`` when the step is below
    ``TIME_STEP_MAX_S`` or fractional, else ``"ms"`` (step < 100) or ``"us"``. Returns (unit, median step)."""
    t_raw = np.asarray(t_raw, dtype=np.float64)
    d = np.diff(t_raw)
    med = float(np.median(d[d > 0])) if np.any(d > 0) else 1.0
    integral = bool(np.all(t_raw == np.round(t_raw)))
    return ("s" if med < TIME_STEP_MAX_S or not integral else ("ms" if med < 100 else "us")), med


def time_unit_problem(t_s: np.ndarray, words: Words = API_WORDS) -> str | None:
    """None if times declared in seconds step like an IMU's (median step < ``TIME_STEP_MAX_S``), else a
    message naming the unit the steps fit (ms or us: the step's size, fractional or not)."""
    d = np.diff(np.asarray(t_s, dtype=np.float64))
    d = d[np.isfinite(d) & (d > 0)]
    if d.size == 0:
        return None
    med = float(np.median(d))
    if med < TIME_STEP_MAX_S:
        return None
    unit = "ms" if med < 100 else "us"
    return (f"time check failed: the median time step {words.data} is {med:.4g}, i.e. a sample rate of "
            f"{1 / med:.3g} Hz if in seconds, slower than any IMU; it fits {unit}: use {words.time.format(unit)}")


def quietest_second(acc_si: np.ndarray, rate_hz: float) -> tuple[float, int]:
    """(median |acc| in the quietest 1-s window, start index of that window)."""
    return quietest_magnitude(np.linalg.norm(acc_si, axis=1), rate_hz)


def quietest_magnitude(mag: np.ndarray, rate_hz: float, window_s: float = 1.0) -> tuple[float, int]:
    """``quietest_second`` of the row norms ``mag`` of the accelerometer (a streamed import keeps only them);
    ``window_s``: another window length (``FOOT_FLAT_S``). The windows' std is taken a few thousand windows at
    a time (the same figures, without a temporary copy of the whole record)."""
    finite = np.isfinite(mag)
    if not finite.all():
        mag = mag[finite]
    n = max(int(round(window_s * rate_hz)) if np.isfinite(rate_hz) else 1, 5)
    if mag.size < n:
        return float(np.median(mag)) if mag.size else float("nan"), 0
    k = mag.size // n
    win = mag[: k * n].reshape(k, n)
    rows = max(1, (1 << 20) // n)
    j = int(np.argmin(np.concatenate([win[a:a + rows].std(axis=1) for a in range(0, k, rows)])))
    return float(np.median(win[j])), j * n


def acc_unit_problem(acc_raw: np.ndarray | None, scale_to_si: float, declared: str, rate_hz: float, *,
                     quiet: tuple[float, int] | None = None, flat: tuple[float, int] | None = None,
                     words: Words = CLI_WORDS) -> str | None:
    """None if the gravity magnitude fits the declared unit, else a message with a suggestion (``quiet``:
    ``quietest_second`` of ``acc_raw`` when already known; ``flat``: the same over ``FOOT_FLAT_S`` windows,
    the rest of a foot that never rests a second (module docstring); ``words``: the remedy's vocabulary)."""
    raw_mag, i0 = quiet or quietest_second(np.asarray(acc_raw, dtype=np.float64), rate_hz)
    if not np.isfinite(raw_mag):
        return None
    if abs(raw_mag * scale_to_si / STANDARD_GRAVITY - 1.0) <= ACC_TOLERANCE:
        return None
    if flat is None and acc_raw is not None:
        flat = quietest_magnitude(np.linalg.norm(np.asarray(acc_raw, dtype=np.float64), axis=1), rate_hz,
                                  FOOT_FLAT_S)
    candidates = [(words.acc.format("g"), 1.0), (words.acc.format("mps2"), STANDARD_GRAVITY)]
    if words.acc_counts:
        candidates += [(words.acc_counts.format(r), 32768.0 / r) for r in (2, 4, 8, 16)]
    where = "quietest second"
    if flat is not None and np.isfinite(flat[0]):
        if abs(flat[0] * scale_to_si / STANDARD_GRAVITY - 1.0) <= ACC_TOLERANCE:
            return None  # a foot that never rests a second: its foot-flats read gravity
        if not any(abs(raw_mag / ref - 1.0) <= ACC_TOLERANCE for _, ref in candidates):
            raw_mag, i0, where = flat[0], flat[1], f"quietest {FOOT_FLAT_S:g} s"
    si = raw_mag * scale_to_si
    fits = [flag for flag, ref in candidates if abs(raw_mag / ref - 1.0) <= ACC_TOLERANCE]
    hint = f"; it fits {fits[0]}" if fits else "; no unit fits (is gravity removed, i.e. linear acceleration?)"
    return (f"gravity check failed: at rest ({where}, from sample {i0}) the median |acc| is {raw_mag:.4g} "
            f"{words.data} = {si:.4g} m/s^2 with the declared unit {declared!r}, expected 9.81 m/s^2 +-25%{hint}")


def gyro_unit_problem(gyro_si: np.ndarray | None, declared: str, *, mag: np.ndarray | None = None,
                      words: Words = CLI_WORDS) -> str | None:
    """None if the gyro's 99.9th percentile |rate| is physically possible, else a message (module docstring);
    ``mag``: the row norms of ``gyro_si`` when already known."""
    if mag is None:
        with np.errstate(over="ignore", invalid="ignore"):  # 1e308 values: refused later by the physical bounds
            mag = np.linalg.norm(np.asarray(gyro_si, dtype=np.float64), axis=1)
    mag = mag[np.isfinite(mag)]
    if mag.size == 0:
        return None
    p = float(np.percentile(mag, 99.9))
    if p <= GYRO_ABSURD_RADPS:
        return None
    hint = words.gyro.format("dps") if declared == "radps" else f"{words.gyro.format('radps')} or {words.gyro_range}"
    return (f"gyro check failed: 99.9th percentile of |rate| is {p:.4g} rad/s with the declared unit {declared!r}, "
            f"more than any foot or MEMS gyro reaches ({GYRO_ABSURD_RADPS} rad/s = 2000 deg/s); try {hint}")


def acc_borderline(acc_raw: np.ndarray | None, scale_to_si: float, rate_hz: float, *,
                   quiet: tuple[float, int] | None = None, words: Words = CLI_WORDS) -> str | None:
    """A warning when the quietest second's |f| passes the gravity check but is 10-25 % off g (module docstring;
    ``quiet`` as in ``acc_unit_problem``)."""
    raw_mag, i0 = quiet or quietest_second(np.asarray(acc_raw, dtype=np.float64), rate_hz)
    si = raw_mag * scale_to_si
    if not np.isfinite(si) or abs(si / STANDARD_GRAVITY - 1.0) <= ACC_BORDERLINE:
        return None
    return (f"gravity borderline: at rest (quietest second, from sample {i0}) |acc| is {si:.4g} m/s^2, "
            f"{100 * (si / STANDARD_GRAVITY - 1):+.0f} % off g; check {words.acc_check}")


def gyro_unit_too_small(acc_si: np.ndarray, gyro_si: np.ndarray, t_s: np.ndarray,
                        declared: str, words: Words = CLI_WORDS) -> tuple[str | None, str | None]:
    """Is the gyro far too small for the motion the accelerometer shows? (module docstring)

    Parameters
    ----------
    acc_si, gyro_si : ndarray, shape (N, 3)
        Specific force in m/s^2 and angular rate in rad/s, converted with the declared units.
    t_s : ndarray, shape (N,)
        Time of each sample, s (the dynamic duration is summed from its intervals).
    declared : str
        The declared gyro unit (``dps``, ``radps``, ``counts``).
    words : Words
        The remedy's vocabulary (``CLI_WORDS`` or ``API_WORDS``).

    Returns
    -------
    (error, warning) : tuple of str or None
        With deg/s declared: ``error`` when the gyro is below 0.3 rad/s while moving (unambiguous),
        ``warning`` when below 0.6 rad/s (borderline); both None otherwise, for other declared units, or
        without enough motion to judge.
    """
    t = np.asarray(t_s, dtype=np.float64)
    if t.size < 2 or declared != "dps":
        return None, None
    with np.errstate(over="ignore", invalid="ignore"):  # 1e308 values: refused later by the physical bounds
        acc_mag = np.linalg.norm(np.asarray(acc_si, dtype=np.float64), axis=1)
        gyro_mag = np.linalg.norm(np.asarray(gyro_si, dtype=np.float64), axis=1)
    dt = np.empty_like(t)
    dt[:-1] = np.diff(t)
    dt[-1] = dt[-2]
    dt = np.where(np.isfinite(dt) & (dt > 0), dt, 0.0)
    dt = np.minimum(dt, 5 * max(float(np.median(dt)), 1e-9))  # a gap is not motion time
    dynamic = np.isfinite(acc_mag) & np.isfinite(gyro_mag) & (np.abs(acc_mag - STANDARD_GRAVITY) > DYNAMIC_ACC_MPS2)
    dyn_s = float(dt[dynamic].sum())
    if dyn_s < MIN_DYNAMIC_S:
        return None, None
    p = float(np.percentile(gyro_mag[dynamic], 99))
    evidence = (f"while the accelerometer shows motion ({dyn_s:.3g} s with ||acc| - g| > {DYNAMIC_ACC_MPS2:g} m/s^2) "
                f"the 99th percentile of |rate| is only {p:.3g} rad/s with the declared unit {declared!r}, "
                f"where a moving foot, waist or hand turns at > {GYRO_MOVING_MIN_RADPS:g} rad/s")
    if p < GYRO_UNIT_ERROR_RADPS:
        return (f"gyro check failed: {evidence}; the data is in rad/s: use {words.gyro.format('radps')} "
                f"(or {words.trust} if the sensor really barely turned)"), None
    if p < GYRO_MOVING_MIN_RADPS:
        return None, (f"gyro suspiciously small: {evidence}; if the data is in rad/s, use "
                      f"{words.gyro.format('radps')}")
    return None, None


def saturation(raw: np.ndarray, full_scale: float, counts: bool, first_bit: int) -> tuple[np.ndarray, list[dict]]:
    """Bitmask (uint8) and one event per run of saturated samples per axis of a (N, 3) block."""
    mask = np.zeros(raw.shape[0], dtype=np.uint8)
    events: list[dict] = []
    if not np.isfinite(full_scale):
        return mask, events
    for axis in range(raw.shape[1]):
        v = raw[:, axis]
        if counts:
            hit = (v >= 32767) | (v <= -32768)
        else:
            hit = np.abs(v) >= full_scale * (1.0 - SI_MARGIN)
        if not hit.any():
            continue
        mask |= (hit.astype(np.uint8) << (first_bit + axis))
        for s, e in zip(*runs(hit)):
            events.append(dict(kind="saturation", sample_index=int(s), axis=first_bit + axis, count=int(e - s),
                               detail=f"{'acc' if first_bit == 0 else 'gyro'} {'xyz'[axis]} at full scale "
                                      f"for {e - s} sample(s)"))
    return mask, events
