"""bootnav's engineered step detector for waist, lower-back and phone sensors (no source paper): band-passed
magnitude, relative-prominence peaks, activity / periodicity / handling gates and a dynamic-programming
"beat tracker" at the local cadence.

Every parameter is ENGINEERED, chosen for one fixed configuration across carrying positions (hand,
pockets, armband, neck pouch, purse, swinging arm, lower back); none is a value of a source. They were
chosen on all developer recordings at once; the measurements behind each choice, and the options measured
and rejected, are in docs/tuning-log.md ("PDR"). ``RobustDetector`` lists every parameter.

Pipeline (fs = 50 Hz after resampling the recording's own clock):

1. a[n] = ||f_b[n]||, orientation-free ([Bayindir2014, eq. 1], [Lazarevskiy2021, eq. 3.1]), band-passed
   x = BP_[0.3, 3.0] Hz(a) (2nd-order Butterworth, zero phase; walking cadence <= 3 Hz [NKUA2009, ch. 2]).
2. Candidates: every local maximum of x with topographic prominence p_k.
   Local reference R_k = 80th percentile of the prominences within +-2.5 s; salience
   s_k = min(p_k / R_k, 1.5) - 0.15: relative, so weak hand / lower-back and strong pocket signals look
   alike; the small offset keeps the weak first and last steps of a walk, whose p_k / R_k is 0.2-0.3.
3. Gates (s_k := -1, the DP then never picks the peak):
   activity: 2-s RMS of x < 0.2 m/s^2 or R_k < 0.1 m/s^2 (standing, phone on a table);
   periodicity: rho(t) = max over the 2.5-s window before and the one after t of
   max_{lag in [0.3, 1.5] s} Pearson(x[w], x[w + lag]) < 0.45 -- walking repeats itself every step or
   stride, handling a phone / sitting down / single bumps do not.
   handling: the device's gravity direction u(t) = LP_0.5Hz(f_b) / |LP_0.5Hz(f_b)| turns by more than
   30 deg between t - 0.5 s and t + 0.5 s. A carried device keeps its mean attitude while walking (median
   1-2 deg, 99th percentile 4-24 deg per Oxford carrying position, < 10 deg on a lower back); putting a phone
   away, taking it out or a pouch settling after the stop turns it by tens of degrees. Such a peak gets
   s_k = -0.5 (not -1): half the break cost, so inside a walk the chain still bridges it (a purse swinging
   hard mid-walk) while at the walk's ends it is never picked.
4. First pass: candidates with p_k >= 0.45 R_k, then minimum spacing 0.6 T_loc (T_loc = local median
   step interval, >= 0.25 s), twice; gives the local step period T(t) (median over +-5 s).
5. Final selection by dynamic programming over candidates (beat tracking):
       B_j = s_j + max( max_i [B_i - lambda (ln((t_j - t_i)/T_j))^2]   for 0.5 T_j <= t_j - t_i <= 1.7 T_j,
                        max_{t_i < t_j - 1.7 T_j} B_i - c_break,  0 )
   lambda = 1, c_break = 1; the best chain is traced back. (lambda = 1: a step 20 % late costs 0.03,
   less than the salience of a weak closing step; a half-period double peak costs ln(2)^2 = 0.48.) This
   picks one peak per step even when a step has two bumps (heel strike + push-off) and bridges a weak step.
6. Onset: leading steps of a bout (gap > 1.6 s) whose prominence is below 0.3 x the bout's median are
   dropped. Gait initiation shows a weak bump (anticipatory weight shift / push-off) about one step before
   the first heel strike: 0.07-0.35 of the median on Voisard's lower back, where the first true step is
   0.41-0.80; at the END the true closing steps are that weak too, so the rule is one-sided.
7. Bouts shorter than 4 steps (gap > 1.6 s) are dropped (isolated bumps are not walking).

Step time = time of the chosen peak of x (no offset).

Options off by default (measured and rejected for the one configuration, figures in the tuning log):
``long_ref_fraction`` (a long-window amplitude gate: removes a pouch still swinging after the stop, but
also the weak closing steps of short walks and the slow sections of a walk that changes speed),
``edge_trim_fraction`` (trims weak bout ends), ``refine_window_s`` / ``event_offset_s`` (move the event
time), ``signal="vertical"`` (specific force along the gravity direction instead of |a|: a front-pocket
phone turns with the thigh every stride).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.detectors.base import StepDetector, register
from bootnav.postproc.pdr.signals import butter_filter, magnitude, resample_uniform
from bootnav.postproc.pdr.steps import StepEvents


def _window_quantile(t_ref: np.ndarray, v: np.ndarray, t_at: np.ndarray, half_s: float, q: float,
                     empty: float = 0.0) -> np.ndarray:
    """q-quantile of the values v (at sorted times t_ref) within +-half_s of each time in t_at."""
    lo = np.searchsorted(t_ref, t_at - half_s)
    hi = np.searchsorted(t_ref, t_at + half_s, side="right")
    return np.array([np.quantile(v[a:b], q) if b > a else empty for a, b in zip(lo, hi)])


def _min_spacing(tp: np.ndarray, prom: np.ndarray, mind: np.ndarray) -> np.ndarray:
    """Keep peaks greedily by prominence so that no two kept peaks are closer than mind (per peak)."""
    sel = np.zeros(tp.size, bool)
    for i in np.argsort(-prom, kind="stable"):
        a = np.searchsorted(tp, tp[i] - mind[i])
        b = np.searchsorted(tp, tp[i] + mind[i], side="right")
        if not sel[a:b].any():
            sel[i] = True
    return sel


def _bouts(tp: np.ndarray, gap_s: float, min_steps: int) -> np.ndarray:
    keep = np.zeros(tp.size, bool)
    if tp.size == 0:
        return keep
    br = np.r_[0, np.nonzero(np.diff(tp) > gap_s)[0] + 1, tp.size]
    for a, b in zip(br[:-1], br[1:]):
        if b - a >= min_steps:
            keep[a:b] = True
    return keep


def periodicity(x: np.ndarray, fs: float, window_s: float, lag_range_s: tuple) -> np.ndarray:
    """Per sample: the larger of the best Pearson autocorrelations (over lags in lag_range_s) of the
    window just before and the window just after the sample. Walking is periodic (r ~ 0.7-1 at the step
    or stride lag); handling a phone, sitting down, single bumps are not. O(N) per lag (cumulative sums)."""
    x = np.asarray(x, float)
    n = x.size
    W = int(round(window_s * fs))
    out_r = np.full(n, -1.0)
    out_l = np.full(n, -1.0)
    S1 = np.r_[0.0, np.cumsum(x)]
    S2 = np.r_[0.0, np.cumsum(x * x)]
    for L in range(max(1, int(lag_range_s[0] * fs)), int(lag_range_s[1] * fs) + 1):
        m = n - W - L + 1  # window starts with both windows inside the data
        if m <= 0:
            break
        P = np.r_[0.0, np.cumsum(x[:-L] * x[L:])]
        st = np.arange(m)
        sa, sb = S1[st + W] - S1[st], S1[st + L + W] - S1[st + L]
        saa, sbb = S2[st + W] - S2[st], S2[st + L + W] - S2[st + L]
        sab = P[st + W] - P[st]
        den = np.sqrt(np.maximum((W * saa - sa * sa) * (W * sbb - sb * sb), 1e-18))
        r = (W * sab - sa * sb) / den
        np.maximum(out_r[:m], r, out=out_r[:m])  # window pair starting at the sample
        np.maximum(out_l[W + L - 1:W + L - 1 + m], r, out=out_l[W + L - 1:W + L - 1 + m])  # ending there
    return np.maximum(out_r, out_l)


def gravity_turn_deg(acc: np.ndarray, fs: float, lowpass_hz: float, half_window_s: float) -> np.ndarray:
    """Per sample: angle (deg) between the low-passed acceleration direction (gravity as seen by the
    device) half_window_s before and half_window_s after. A device carried in a pocket, purse, pouch, hand
    or on the body keeps its mean attitude while walking (angle ~1-5 deg); being put away, taken out or
    handled turns it by tens of degrees."""
    g = butter_filter(np.asarray(acc, float), fs, lowpass_hz, "low", order=2)
    g = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-9)
    n = max(1, int(round(half_window_s * fs)))
    gp = np.concatenate([np.repeat(g[:1], n, 0), g, np.repeat(g[-1:], n, 0)])
    return np.degrees(np.arccos(np.clip(np.sum(gp[:-2 * n] * gp[2 * n:], axis=1), -1.0, 1.0)))


@register("robust")
@dataclass
class RobustDetector(StepDetector):
    """Engineered default detector (equations in the module docstring; every value engineered).

    Parameters
    ----------
    fs_hz : float
        Rate the recording is resampled to, Hz: well above twice the 3-Hz band edge, cheap to process.
    band_hz : tuple of float
        Band-pass of |a|, Hz: 0.3 removes gravity drift and posture changes, 3.0 passes the fastest walking
        cadence [NKUA2009, ch. 2] and drops impact ringing.
    ref_half_window_s, ref_quantile : float
        Window (+-s) and quantile of the local prominence reference R_k: a few steps either side, high
        enough that the walk's typical step, not its weakest, sets the scale.
    first_pass_rel_prominence : float
        Prominence (fraction of R_k) a candidate needs in the first pass that estimates the cadence.
    spacing_factor, min_spacing_s : float
        First pass: minimum distance between kept peaks, as a fraction of the local step interval and in
        s (0.25 s: faster than any walking cadence).
    period_half_window_s : float
        Window (+-s) of the local median step interval T(t).
    salience_offset, salience_cap : float
        s_k = min(p_k / R_k, cap) - offset: the offset is the relative prominence below which a peak costs
        rather than gains; the cap keeps one huge bump from paying for a wrong chain.
    activity_rms_mps2, activity_window_s : float
        Activity gate: RMS of the band-passed signal over the window below which nobody walks, m/s^2, s.
    ref_floor_mps2 : float
        Activity gate on R_k, m/s^2: a reference prominence this small is sensor noise, not steps.
    interval_penalty : float
        lambda, the cost of a step interval off the local period: lambda (ln(dt / T))^2.
    interval_range : tuple of float
        Allowed step interval as fractions of T (0.5-1.7): a half-period double bump or one missed step.
    break_cost : float
        c_break, the cost of restarting a chain after a gap (a pause, a bridged weak step).
    bout_gap_s, min_bout_steps : float, int
        Steps further apart than bout_gap_s (s) start a new bout; a bout of fewer steps is dropped.
    default_period_s : float
        Step period assumed where the cadence cannot be estimated yet, s (typical walking: 0.5-0.6 s).
    periodicity_min, periodicity_window_s : float
        Periodicity gate: smallest windowed autocorrelation (Pearson r) of walking, and the window, s.
    periodicity_lags_s : tuple of float
        Lags searched, s: from the shortest step to the longest stride.
    edge_trim_fraction : float
        Off (0). Drop bout-start and bout-end steps below this fraction of the bout's median prominence.
    onset_trim_fraction : float
        Drop leading bout steps below this fraction of the bout's median prominence (step 6).
    signal : str
        "magnitude" (|a|) or "vertical" (projection on the low-passed gravity direction; off).
    long_ref_half_window_s, long_ref_fraction : float
        Off (fraction 0). Gate peaks whose R_k is below that fraction of the same quantile over +-window s.
    refine_window_s : tuple of float or None
        Off (None). Move each event to the largest lightly filtered |a| within this window around it, s.
    refine_lowpass_hz : float
        Low-pass of that refinement, Hz.
    event_offset_s : float
        Constant shift added to every event time, s (0: the peak itself).
    handling_max_deg, handling_lowpass_hz, handling_half_window_s : float
        Handling gate: largest turn (deg) of the gravity direction (low-passed at this Hz) between
        t -/+ the half window (s) that still counts as carried walking (module docstring, step 3).
    handling_salience : float
        Salience of a peak during handling: -0.5 = half the break cost (bridged mid-walk, never at an end).
    """

    fs_hz: float = 50.0
    band_hz: tuple = (0.3, 3.0)
    ref_half_window_s: float = 2.5
    ref_quantile: float = 0.8
    first_pass_rel_prominence: float = 0.45
    spacing_factor: float = 0.6
    min_spacing_s: float = 0.25
    period_half_window_s: float = 5.0
    salience_offset: float = 0.15
    salience_cap: float = 1.5
    activity_rms_mps2: float = 0.2
    activity_window_s: float = 2.0
    ref_floor_mps2: float = 0.1
    interval_penalty: float = 1.0
    interval_range: tuple = (0.5, 1.7)
    break_cost: float = 1.0
    bout_gap_s: float = 1.6
    min_bout_steps: int = 4
    default_period_s: float = 0.55
    periodicity_min: float = 0.45
    periodicity_window_s: float = 2.5
    periodicity_lags_s: tuple = (0.3, 1.5)
    edge_trim_fraction: float = 0.0
    onset_trim_fraction: float = 0.3
    signal: str = "magnitude"
    long_ref_half_window_s: float = 15.0
    long_ref_fraction: float = 0.0
    refine_window_s: tuple | None = None
    refine_lowpass_hz: float = 6.0
    event_offset_s: float = 0.0
    handling_max_deg: float = 30.0
    handling_lowpass_hz: float = 0.5
    handling_half_window_s: float = 0.5
    handling_salience: float = -0.5

    def _first_pass(self, tp, prom, R):
        ok = (prom >= self.first_pass_rel_prominence * R) & (R >= self.ref_floor_mps2)
        t1, p1 = tp[ok], prom[ok]
        for _ in range(2):
            if t1.size < 3:
                break
            iv = np.diff(t1)
            mid = 0.5 * (t1[1:] + t1[:-1])
            good = iv < self.bout_gap_s
            med = (_window_quantile(mid[good], iv[good], t1, 1.5 * self.ref_half_window_s, 0.5,
                                    self.default_period_s) if good.any() else np.full(t1.size, self.default_period_s))
            sel = _min_spacing(t1, p1, np.maximum(self.min_spacing_s, self.spacing_factor * med))
            t1, p1 = t1[sel], p1[sel]
        return t1

    def _local_period(self, t1, t_at):
        if t1.size >= 3:
            iv = np.diff(t1)
            good = iv < self.bout_gap_s
            if good.any():
                mid = 0.5 * (t1[1:] + t1[:-1])
                T = _window_quantile(mid[good], iv[good], t_at, self.period_half_window_s, 0.5, 0.0)
                T[T <= 0] = float(np.median(iv[good]))
                return T
        return np.full(t_at.size, self.default_period_s)

    def _beat_track(self, tp, sal, T):
        n = tp.size
        best = np.full(n, -np.inf)
        prev = np.full(n, -1)
        pref = np.full(n, -np.inf)
        pref_arg = np.full(n, -1)
        lo_f, hi_f = self.interval_range
        for j in range(n):
            a = np.searchsorted(tp, tp[j] - hi_f * T[j])
            b = np.searchsorted(tp, tp[j] - lo_f * T[j], side="right")
            cont, ci = -np.inf, -1
            if b > a:
                v = best[a:b] - self.interval_penalty * np.log((tp[j] - tp[a:b]) / T[j]) ** 2
                k = int(np.argmax(v))
                cont, ci = v[k], a + k
            start, si = 0.0, -1
            if a > 0 and pref[a - 1] - self.break_cost > 0:
                start, si = pref[a - 1] - self.break_cost, pref_arg[a - 1]
            if start >= cont:
                best[j], prev[j] = sal[j] + start, si
            else:
                best[j], prev[j] = sal[j] + cont, ci
            if j > 0 and pref[j - 1] >= best[j]:
                pref[j], pref_arg[j] = pref[j - 1], pref_arg[j - 1]
            else:
                pref[j], pref_arg[j] = best[j], j
        sel = []
        j = pref_arg[-1] if n and pref[-1] > 0 else -1
        while j >= 0:
            sel.append(j)
            j = prev[j]
        return np.array(sel[::-1], int)

    def _trim_edges(self, ts, pr):
        """Drop steps at the start (``onset_trim_fraction``) and/or the start and end
        (``edge_trim_fraction``) of each bout whose prominence is below that fraction x the bout's median."""
        keep = np.ones(ts.size, bool)
        br = np.r_[0, np.nonzero(np.diff(ts) > self.bout_gap_s)[0] + 1, ts.size]
        for a_, b_ in zip(br[:-1], br[1:]):
            med = np.median(pr[a_:b_])
            ref_start = max(self.edge_trim_fraction, self.onset_trim_fraction) * med
            i, j = a_, b_ - 1
            while i <= j and pr[i] < ref_start:
                keep[i] = False
                i += 1
            while j >= i and pr[j] < self.edge_trim_fraction * med:
                keep[j] = False
                j -= 1
        return ts[keep]

    def detect(self, t_s, acc_b) -> StepEvents:
        from scipy import signal

        tg, a = resample_uniform(t_s, acc_b, self.fs_hz)
        if self.signal == "vertical":
            g = butter_filter(a, self.fs_hz, self.handling_lowpass_hz, "low", order=2)
            g = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-9)
            raw = np.sum(a * g, axis=1)
        else:
            raw = magnitude(a)
        x = butter_filter(raw, self.fs_hz, list(self.band_hz), "band", order=2)
        pk, props = signal.find_peaks(x, prominence=0)
        prom = props["prominences"]
        tp = tg[pk]
        R = _window_quantile(tp, prom, tp, self.ref_half_window_s, self.ref_quantile)
        t1 = self._first_pass(tp, prom, R)
        T = self._local_period(t1, tp)
        sal = np.minimum(prom / np.maximum(R, 1e-9), self.salience_cap) - self.salience_offset
        nw = max(1, int(round(self.activity_window_s * self.fs_hz)))
        rms = np.sqrt(np.convolve(x ** 2, np.ones(nw) / nw, mode="same"))
        sal[(R < self.ref_floor_mps2) | (rms[pk] < self.activity_rms_mps2)] = -1.0
        if self.long_ref_fraction > 0:
            R_long = _window_quantile(tp, prom, tp, self.long_ref_half_window_s, self.ref_quantile)
            sal[R < self.long_ref_fraction * R_long] = -1.0
        tilt = None
        if self.handling_max_deg > 0:
            tilt = gravity_turn_deg(a, self.fs_hz, self.handling_lowpass_hz, self.handling_half_window_s)
            sal[tilt[pk] > self.handling_max_deg] = self.handling_salience
        per = None
        if self.periodicity_min > 0:
            per = periodicity(x, self.fs_hz, self.periodicity_window_s, self.periodicity_lags_s)
            sal[per[pk] < self.periodicity_min] = -1.0
        sel = self._beat_track(tp, sal, T)
        ts = tp[sel]
        if (self.edge_trim_fraction > 0 or self.onset_trim_fraction > 0) and ts.size:
            ts = self._trim_edges(ts, prom[sel])
        if self.refine_window_s is not None and ts.size:
            # move each event to the impact peak of the lightly filtered magnitude near the smooth peak
            mf = butter_filter(magnitude(a), self.fs_hz, self.refine_lowpass_hz, "low", order=2)
            lo = np.searchsorted(tg, ts + self.refine_window_s[0])
            hi = np.searchsorted(tg, ts + self.refine_window_s[1], side="right")
            ts = np.array([tg[a_ + int(np.argmax(mf[a_:b_]))] if b_ > a_ else t_ for a_, b_, t_ in zip(lo, hi, ts)])
        ts = ts + self.event_offset_s
        keep = _bouts(ts, self.bout_gap_s, self.min_bout_steps)
        return StepEvents(ts[keep], self.name,
                          {"t_s": tg, "signal": x, "signal_label": "band-passed |a| (m/s^2)",
                           "candidates_t_s": tp, "activity_rms": rms, "period_s": T,
                           "periodicity": per, "gravity_turn_deg": tilt})
