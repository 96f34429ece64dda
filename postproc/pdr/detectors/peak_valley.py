"""[NKUA2009] waist peak/valley detector: 8-sample moving average, alternating
extrema, amplitude gates, K (Amax - Amin)^(1/4) step length. [NKUA2009, §2.1, §5.2, appendix code Π3–Π5].

Equations / rules ([NKUA2009]; Π = its C# code listing):
* moving average: documented  f[i] = (1/8) sum_{j=i-7..i} z[j];
  literal (C# Π3)  f[i] = mean(z[i-1..i-7] within the buffer, topped up from the 8-sample carry-over
  storage of RAW values until 8 values or the storage runs out); f[0] = z[0].
* sign s[i] = '+' if f[i] - f[i-1] >= 0 else '-' (Π4); a sign change counts only if
  i >= last_extremum + 4 samples (Π4); '-'->'+' (trough) then '+'->'-' (crest) = candidate step at the
  crest + 1 sample if raw range of z since the buffer start >= 0.20 (Π4).
* acceptance (Π5): raw z range >= 0.20 AND (raw x range >= 0.15 OR raw y range >= 0.15).
* threads (literal): rescan the whole buffer every 4 samples (200 ms); consume a candidate after
  ``process_delay_samples``; then storage := 8 newest raw samples (newest first), drop buffer[0..crest];
  buffer > 201 samples -> drop the first 50.

Literal parameters (defaults): fs 20 Hz, n_ma 8, gap 4 samples, gates 0.20 / 0.15 in ``acc_unit`` (the
code's unit is ambiguous: we apply them in g, which makes K = 0.95 plausible [reconstructed]),
scan every 4 samples. ``literal=False`` = the thesis prose: clean moving average of the last 8 samples,
scan every sample, no delay (an idealised sequential variant), vertical axis = gravity direction.
Quirk kept in literal mode: steps faster than ~2 steps/s are under-counted (a property of
[NKUA2009, appendix code Π4] at 20 Hz).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.detectors._axes import to_unit, vertical_and_horizontal
from bootnav.postproc.pdr.detectors.base import StepDetector, register
from bootnav.postproc.pdr.signals import resample_uniform
from bootnav.postproc.pdr.steps import StepEvents


def literal_moving_average(raw: list, storage: list, n: int = 8) -> float:
    """C# Π3 filtered value for the newest element of ``raw`` (literal)."""
    if len(raw) == 1:
        return raw[0]
    vals = raw[max(len(raw) - n, 0):len(raw) - 1][::-1]  # indices Count-2 .. Count-8 (7 previous)
    vals = list(vals)
    k = 0
    while len(vals) < n and k < len(storage):
        vals.append(storage[k])
        k += 1
    return sum(vals) / len(vals)


def wrap_heading_average(values: list[float], normalize: bool = False) -> float:
    """[NKUA2009, Π3]: average headings (deg) relative to the FIRST value: h-360 if h-ref > 180, h+360 if
    h-ref < -180; literal result not re-normalised (may be < 0 or >= 360)."""
    ref = values[0]
    acc = [h - 360 if h - ref > 180 else h + 360 if h - ref < -180 else h for h in values]
    m = sum(acc) / len(acc)
    return m % 360.0 if normalize else m


@register("peak_valley")
@dataclass
class PeakValleyDetector(StepDetector):
    literal: bool = True
    fs_hz: float = 20.0
    n_ma: int = 8
    min_extrema_gap: int = 4
    min_z_range: float = 0.20
    min_hor_range: float = 0.15
    acc_unit: str = "g"
    scan_every: int = 4
    scan_phase: int = 0
    process_delay_samples: int = 0
    max_buffer: int = 201
    drop_on_overflow: int = 50
    axes: str = ""  # "" -> "sensor" if literal else "gravity"

    def detect(self, t_s, acc_b) -> StepEvents:
        tg, a = resample_uniform(t_s, acc_b, self.fs_hz)
        z, x, y = (to_unit(c, self.acc_unit) for c in
                   vertical_and_horizontal(a, self.fs_hz, self.axes or ("sensor" if self.literal else "gravity")))
        scan_every = self.scan_every if self.literal else 1
        delay = self.process_delay_samples if self.literal else 0
        raw = {"z": [], "x": [], "y": []}
        filt: list[float] = []
        storage: list[float] = []
        base = 0  # absolute index of buffer element 0
        pending = None  # (absolute sample when detected, crest index in buffer, ranges)
        steps, amp, rejected = [], [], []
        drops, max_len = 0, 0
        for i in range(z.size):
            for k, arr in (("z", z), ("x", x), ("y", y)):
                raw[k].append(arr[i])
            if self.literal:
                filt.append(literal_moving_average(raw["z"], storage, self.n_ma))
            else:
                w = raw["z"][-self.n_ma:]
                filt.append(sum(w) / len(w))
            if pending is None and (i - self.scan_phase) % scan_every == 0:
                if len(raw["z"]) - 1 > self.max_buffer:
                    d = self.drop_on_overflow
                    for k in raw:
                        del raw[k][:d]
                    del filt[:d]
                    base += d
                    drops += 1
                pending = self._scan(raw, filt, i)
            max_len = max(max_len, len(filt))
            if pending is not None and i - pending[0] >= delay:
                _, crest, rz, rx, ry = pending
                storage = raw["z"][-self.n_ma:][::-1] if self.literal else []
                if rz >= self.min_z_range and (rx >= self.min_hor_range or ry >= self.min_hor_range):
                    steps.append(base + crest)
                    amp.append(rz)
                else:
                    rejected.append(base + crest)
                for k in raw:
                    del raw[k][:crest + 1]
                del filt[:crest + 1]
                base += crest + 1
                pending = None
        idx = np.array(steps, int)
        return StepEvents(tg[idx] if idx.size else np.zeros(0), self.name,
                          {"t_s": tg, "signal": z, "signal_label": f"vertical acceleration ({self.acc_unit})",
                           "z_range": np.array(amp), "overflow_drops": drops, "max_buffer_len": max_len,
                           "rejected_t_s": tg[np.array(rejected, int)] if rejected else np.zeros(0)})

    def _scan(self, raw, filt, now):
        """One Stride_Check pass over the buffer (Π4); returns a candidate or None."""
        n = len(filt)
        if n < 2:
            return None
        f = np.asarray(filt)
        rz, rx, ry = (np.asarray(raw[k]) for k in ("z", "x", "y"))
        last_el, last_type, last_sign = 0, "minimum", "-"
        zmax = np.maximum.accumulate(rz); zmin = np.minimum.accumulate(rz)
        xr = np.maximum.accumulate(rx) - np.minimum.accumulate(rx)
        yr = np.maximum.accumulate(ry) - np.minimum.accumulate(ry)
        signs = np.where(np.diff(f) >= 0, "+", "-")
        for xi in range(1, n):
            cur = signs[xi - 1]
            if cur != last_sign and xi >= last_el + self.min_extrema_gap:
                if last_sign == "-" and cur == "+":  # trough (the code calls it "maximum")
                    if last_type != "maximum":
                        last_el, last_type = xi, "maximum"
                else:  # crest (the code calls it "minimum")
                    if last_type != "minimum":
                        last_type = "minimum"
                        if zmax[xi] - zmin[xi] >= self.min_z_range:
                            return (now, xi, zmax[xi] - zmin[xi], xr[xi], yr[xi])
            last_sign = cur
        return None
