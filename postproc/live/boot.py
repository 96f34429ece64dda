"""One boot in the live view: streaming navigation, strides, floors, distance, time since the last motion.

The samples go through the streaming stance detector and the streaming ZUPT filter of ``process``
(``detectors.stream.StreamStance``, ``ins.stream.StreamNavigator``: the same detector, filter, measurement
models and settings object, pushed chunk by chunk). The filter returns rows once the fixed-lag smoother
has made them final (at the end of the stance phase that closes a swing), so a stride appears when the
foot leaves the ground again. From the final rows the view builds what ``process`` reports:

* footprints: the mean position over each stance phase (``strides.FootprintAccumulator``, across chunks);
* strides: moves of at least ``selftune.min_stride_m`` between footprints (``strides.stride_footprints``);
* floor and height: with ``floor_storeys`` (default) the storeys' rules of ``process`` (``floors.storey_offsets``:
  lone strides, flights counted in risers, landings on storeys, storey numbers) on the footprints so far, so
  causal: a flight's landing corrects the footprints after it, never one already shown; without, the level
  of each footprint's height above the first one (``strides.floor_signal`` and ``strides.floor_levels``,
  continued from the last level: both are shift-invariant by one storey);
* distance: the sum of the horizontal stride lengths;
* uncertainty: each stride row ends with the footprint's horizontal 1-σ ellipse (``strides.ellipse``:
  semi-major, semi-minor in m, orientation in rad counter-clockwise from east) from the forward filter's
  covariance at the last sample of its stance phase, where the fixed-lag smoother ends every segment on the
  filtered estimate, plus the sensor's scale and cross-axis errors propagated along the path so far
  (``ellipses.ScaleErrorAccumulator``: causal, the same terms as ``process``'s ``steps.csv``).

Provisional strides (``provisional``): as soon as a low-latency cue says the foot has stopped, the view
draws a provisional footprint at the navigator's filtered position propagated to that stance start; the final
stride replaces it when its rows are final (``provisional`` module docstring).

Time since the last motion is read from the stance decisions, which come a detector window after the
samples (long before the rows are final): the foot counts as moving while it is not in stance. A boot that
stops sending is no safer than one that stands still: while its link is not ``ok`` (stale, disconnected, never
heard) the wall time without samples adds to the time without motion, so the same alarm fires after
``no_motion_s``, marked ``signal lost`` (``status``).

A stream that breaks off (a ``disconnect`` event: cable pulled, emulator ended) ends the boot's segment as the
end of a record does: the filter is flushed and the open stance phase closed, so its last stride is final on
the page as in ``live.json``. Samples after a reconnect start a new segment, aligned on its own initial rest and
continued from the last footprint (the heading is re-aligned: the turn made while the link was down is
unknown; a note says so).

The sensor calibration is ``process``'s (``calibration.resolve_calibration`` with the recording's device id,
``apply_calibration`` with its temperature): every chunk is calibrated as it arrives, before the detector,
the cue and the navigator see it.

What ``process`` does on the whole record and a stream cannot (``ins.stream``): the stance fallback
(the fallback of ``pipeline``'s passes) and the per-recording vertical timing calibration; the live view uses the
configured detector and no timing offset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from bootnav.errors import InputError
from bootnav.postproc.ellipses import ScaleErrorAccumulator, scale_sigmas, unwrapped_yaw
from bootnav.postproc.strides import FootprintAccumulator, ellipse, floor_levels, floor_signal, stride_footprints

ROW_COLUMNS = ["t_s", "x_m", "y_m", "z_m", "floor", "ellipse_major_m", "ellipse_minor_m", "ellipse_orientation_rad"]

from .link import LinkStatus
from .provisional import RecentSamples, propagate_position


@dataclass
class LiveSettings:
    """Tunables of the live view (saved in ``live.json`` with the ``ProcessSettings`` used).

    Attributes
    ----------
    no_motion_s : float, s
        Time without motion before the alarm: 30 s is the PASS-device rule [NFPA1982].
    flush_interval_s : float, s
        The recorders' flush interval: the view sees samples at most this late (``record`` default 0.5 s).
    poll_s : float, s
        Time between two polls of the growing files.
    stale_s : float, s
        Wall-clock time without a new sample before a live link is shown as stale.
    rate_window_s : float, s
        Device-time window of the link's rate figure.
    cue_min_stance_s : float, s
        The provisional-stride cue: how long SHOE's statistic must stay under its threshold before a stance
        start is believed. 0.05 s is the ``adaptive`` detector's own minimum stance (a shorter quiet run is a
        dip within a swing); it adds as much to the provisional latency.
    """

    no_motion_s: float = 30.0
    flush_interval_s: float = 0.2
    poll_s: float = 0.1
    stale_s: float = 2.0
    rate_window_s: float = 2.0
    cue_min_stance_s: float = 0.05


def warm_up(settings) -> None:
    """Load (or compile) the numerical kernels by navigating 3 s of a synthetic rest, so that the first boot's
    first samples do not wait for it (run it in a thread while the recorders connect)."""
    from bootnav.postproc.detectors.stream import StreamStance
    from bootnav.postproc.ins.stream import StreamNavigator

    rate = 200.0
    t = np.arange(int(3 * rate)) / rate
    acc = np.tile([0.0, 0.0, settings.calibration.gravity()], (len(t), 1))
    gyro = np.zeros((len(t), 3))
    nav = StreamNavigator.from_still(settings, rate, t, acc, gyro)
    stance = StreamStance(settings.detector, rate, gravity=nav.gravity)
    for d in stance.push(t, acc, gyro) + stance.finish():
        nav.push(d.t_s, d.acc_b, d.gyro_b, d.stance)
    nav.finish()
    propagate_position(np.zeros(3), np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.zeros(3), 0.0,
                       t[:2], acc[:2], gyro[:2], np.zeros(2, bool), nav.gravity)


class BootView:
    """The live state of one boot: push chunks of samples, get the new stride rows, read the status.

    Parameters
    ----------
    label : str
        Name of the boot (legend, files).
    settings : ProcessSettings
        Detector, filter, calibration, floors and minimum stride, as for ``process``.
    live : LiveSettings
    """

    def __init__(self, label: str, settings, live: LiveSettings):
        self.label = label
        self.settings = settings
        self.live = live
        self.floors = settings.floor_settings()
        self.min_stride_m = settings.selftune.min_stride_m
        self.link = LinkStatus(live.rate_window_s, live.stale_s)
        self.note: str | None = None
        self._fp = FootprintAccumulator()
        self._n_fp = 0  # footprints already turned into rows
        self._nav = None
        self._ahead = np.zeros(0, bool)  # stance decisions of the pushed samples not yet final
        self._pending: list = []  # chunks waiting for the navigator to start (its initial still period)
        self._rows: list[list[float]] = []  # ROW_COLUMNS per kept footprint, the start first
        self._ends_cov: list[tuple[float, float, float]] = []  # (P_EE, P_NN, P_EN) at each stance phase's end
        self._ends_yaw: list[float] = []  # the foot's unwrapped yaw there, rad (``ellipses``)
        self._yaw_last: float | None = None  # unwrapped yaw of the last final row
        self._scale_cov = None  # ellipses.ScaleErrorAccumulator, made at the first footprint (calibration known)
        self._in_stance = False  # the last final row was in stance (its phase may go on in the next rows)
        self._last_kept: np.ndarray | None = None
        self._z0: float | None = None  # height of the first footprint
        self._fp_last_z = 0.0  # height (relative) and floor signal of the last footprint
        self._signal_last = 0.0
        self._level = 0
        self._fp_seen: list[np.ndarray] = []  # every footprint so far, as the filter gave it (storeys' input)
        self._z_storey = 0.0  # the storeys' height correction of the last footprint (provisional rows get it)
        self._distance_m = 0.0
        self._t_latest = float("nan")  # newest stance decision
        self._t_motion: float | None = None  # newest moving sample
        self._t_start: float | None = None
        self._stopped = False  # the filter refused the samples: no more path for this boot
        self._prov: list[list[float]] = []  # provisional rows [t_s, x_m, y_m, z_m, floor] after the final ones
        self._covered_t = -np.inf  # provisional rows up to this time are superseded by final rows
        self._offset_n = np.zeros(3)  # position of this segment's origin (the last footprint of the previous one)
        self._segment_ended = False  # the stream broke off: the next samples start a new segment
        self._segment_note: str | None = None
        self._wall0: float | None = None  # wall time of the first status (a boot never heard is silent since)
        self.calibration = None  # calibration.AppliedCalibration, resolved at the first chunk
        # the navigator gets calibrated samples: its own settings must not calibrate them again
        self._nav_settings = replace(settings, calibration=replace(settings.calibration, sensor_calibration="none",
                                                                   accel_calibration_file=None))
        # heading_aid "auto": the rule of building.directions on the strides seen so far (causal)
        self._dirs = None
        if settings.filter.heading_aid == "auto" and settings.filter.mode != "riccati":  # no yaw gain there
            from bootnav.postproc.building.directions import CausalDirections

            self._dirs = CausalDirections(settings.filter)

    # ------------------------------------------------------------------ samples in
    def push(self, chunk, wall_s: float) -> list[list[float]]:
        """Account for a chunk (``sources.Chunk``); return the stride rows it completed."""
        self.link.update(chunk.t_s, chunk.saturated, chunk.events, wall_s)
        rows: list[list[float]] = []
        if len(chunk.t_s) and not self._stopped:
            if self._t_start is None:
                self._t_start = float(chunk.t_s[0])
            if self._segment_ended:
                self._new_segment()
            try:
                chunk = self._calibrated(chunk)
            except InputError as exc:
                self._stopped = True
                self.note = f"path stopped: {exc}"
                return rows
            rows = self._guarded(chunk)
        broke_off = len(chunk.events) and bool((chunk.events["kind"] == b"disconnect").any())
        if broke_off:
            rows += self.finish()  # the stream broke off: its last stride is final now, not at the next sample
        return rows

    def _calibrated(self, chunk):
        """The chunk with the sensor calibration applied (resolved once, from the first chunk's device id)."""
        from bootnav.postproc.calibration import apply_calibration, resolve_calibration

        if self.calibration is None:
            self.calibration = resolve_calibration(self.settings.calibration, getattr(chunk, "device_id", None))
        if self.calibration.calibration is None:
            return chunk
        n_warn = len(self.calibration.warnings)
        acc, gyro = apply_calibration(self.calibration, chunk.acc_mps2, chunk.gyro_radps,
                                      getattr(chunk, "temp_degc", None))
        if len(self.calibration.warnings) > n_warn:
            self.note = self.calibration.warnings[-1]
        return replace(chunk, acc_mps2=acc, gyro_radps=gyro)

    def finish(self) -> list[list[float]]:
        """The end of the record (or of the stream, at a disconnect): flush the filter and close the last
        stance phase; a second call returns nothing."""
        if self._segment_ended:
            return []
        self._segment_ended = True
        rows = [] if self._stopped else self._guarded(None)
        self._fp.finish()
        self._prov = []
        return rows + self._add_footprints(*self._new_footprints())

    def _new_segment(self) -> None:
        """Samples after a broken-off stream: a new navigator (aligned on the next rest) whose origin is the last
        footprint, so the path continues from where the boot was last seen (module docstring)."""
        self._nav = None
        self._pending = []
        self._ahead = np.zeros(0, bool)
        self._fp = FootprintAccumulator()
        self._n_fp = 0
        self._prov = []
        self._covered_t = -np.inf
        self._segment_ended = False
        if self._last_kept is not None:
            self._offset_n = np.asarray(self._last_kept, float).copy()  # heights stay relative to the first start
            self._segment_note = "signal back after a loss: path continued from the last footprint, heading re-aligned"
            self.note = self._segment_note

    @property
    def cue_lookahead_s(self) -> float | None:
        """How long after a stance start its provisional row comes at the earliest, s (None before the start)."""
        return self._cue.lookahead_s if self._nav is not None else None

    @property
    def provisional(self) -> list[list[float]]:
        """The provisional stride rows (``[t_s, x_m, y_m, z_m, floor]``, ``t_s`` the cue's stance start) not yet
        replaced by final ones, oldest first."""
        return [list(r) for r in self._prov]

    def _guarded(self, chunk) -> list[list[float]]:
        """Navigate; samples the filter refuses (time going backwards, non-finite values) stop this boot's
        path with a note on its panel, while its recorder and link status go on."""
        try:
            return self._final_rows(*self._navigate(chunk))
        except InputError as exc:
            self._stopped = True
            self.note = f"path stopped: {exc}"
            return []

    def _navigate(self, chunk):
        """(t_s, pos_n, stance) of the rows that became final; ``chunk`` None: the end of the record."""
        if self._nav is None:
            self._pending.append(chunk)
            if not self._start():
                return np.zeros(0), np.zeros((0, 3)), np.zeros(0, bool)
            chunks, self._pending = self._pending, []
        else:
            chunks = [chunk]
        parts = []
        for c in chunks:
            if c is None:
                decided = self._stance.finish()
            else:
                self._sat = np.concatenate((self._sat, c.saturated))
                decided = self._stance.push(c.t_s, c.acc_mps2, c.gyro_radps, c.saturated)
            for d in decided:
                n = len(d.t_s)
                sat, self._sat = self._sat[:n], self._sat[n:]
                self._motion(d.t_s, d.stance)
                self._ahead = np.concatenate((self._ahead, np.asarray(d.stance, bool)))
                parts.append(self._nav.push(d.t_s, d.acc_b, d.gyro_b, d.stance, sat))
                if len(parts[-1]):
                    self._bias = (parts[-1].acc_bias_b[-1], parts[-1].gyro_bias_b[-1])
            if c is None:
                parts.append(self._nav.finish())
            else:
                self._cue_push(c)
        if not parts:
            return np.zeros(0), np.zeros((0, 3)), np.zeros(0, bool)
        from bootnav.postproc.ins.stream import NavRows

        rows = NavRows.concatenate(parts)
        self._ahead = self._ahead[len(rows):]
        self._phase_end_covariances(rows)
        return rows.t_s, rows.pos_n, rows.stance

    def _phase_end_covariances(self, rows) -> None:
        """Keep the horizontal covariance at the last row of every stance phase (one entry per phase, in the
        order the footprint accumulator closes them; a phase still open at the end of ``rows`` is updated by
        the next rows)."""
        st = np.asarray(rows.stance, bool)
        if not len(st):
            return
        ends = np.flatnonzero(st & np.append(~st[1:], True))
        if self._in_stance and st[0] and len(ends) and self._ends_cov:
            self._ends_cov.pop()  # the open phase goes on: its end moves
            self._ends_yaw.pop()
        sig, cen = rows.pos_sigma_n, rows.pos_cov_en
        self._ends_cov.extend((float(sig[i, 0] ** 2), float(sig[i, 1] ** 2), float(cen[i])) for i in ends.tolist())
        yaw = unwrapped_yaw(rows.q_nb)
        if self._yaw_last is not None:  # continue the unwrapping across chunks
            yaw = yaw + 2 * np.pi * np.round((self._yaw_last - yaw[0]) / (2 * np.pi))
        self._yaw_last = float(yaw[-1])
        self._ends_yaw.extend(float(yaw[i]) for i in ends.tolist())
        self._in_stance = bool(st[-1])

    def _start(self) -> bool:
        """Start the navigator once the initial rest is complete (as ``process`` aligns on it).

        The buffered samples are aligned on when a still period found in them has ended (the boot moved),
        when they span ``still_search_s + max_still_s`` (all ``process`` would look at), or at the end of the
        record. With no still period within ``still_search_s`` the oldest samples are dropped, so the view
        starts after the next rest.
        """
        from bootnav.postproc.calibration import find_still_period, stance_reference
        from bootnav.postproc.detectors.stream import StreamStance
        from bootnav.postproc.ins.stream import StreamNavigator

        final = self._pending[-1] is None
        got = [c for c in self._pending if c is not None and len(c.t_s)]
        if not got:
            return False
        t = np.concatenate([c.t_s for c in got])
        acc = np.concatenate([c.acc_mps2 for c in got])
        gyro = np.concatenate([c.gyro_radps for c in got])
        cal = self.settings.calibration
        span = float(t[-1] - t[0])
        if span < cal.min_still_s:  # not even the shortest still period yet
            if final:
                self.note = "too short to align on: no path"
            return False
        still = find_still_period(t, acc, gyro, min_duration_s=cal.min_still_s, settings=cal, gravity=cal.gravity())
        # no stance decisions yet: the boot is still while the buffer ends in its still period, else moving
        self._t_latest = float(t[-1])
        if still is None or still.stop < len(t):
            self._t_motion = float(t[-1])
        if still is None and not final:
            if span > cal.still_search_s:  # no rest near the start of the buffer: slide it
                cut = t[-1] - cal.still_search_s
                self._pending = []
                for c in got:
                    m = c.t_s >= cut
                    if m.any():
                        self._pending.append(replace(c, t_s=c.t_s[m], acc_mps2=c.acc_mps2[m],
                                                     gyro_radps=c.gyro_radps[m], saturated=c.saturated[m]))
                self.note = "waiting for the boot to stand still (alignment)"
            return False
        if not (final or span >= cal.still_search_s + cal.max_still_s or (still is not None and still.stop < len(t))):
            return False
        if still is None:
            self.note = "no still period to align on: no path"
            return False
        rate_hz = 1.0 / float(np.median(np.diff(t))) if len(t) > 1 else float("nan")
        self._nav = StreamNavigator.from_still(self._nav_settings, rate_hz, t, acc, gyro)
        bias_det, gravity_det = stance_reference(self._nav.init_state, self._nav.gravity)  # as ``process``
        self._stance = StreamStance(self.settings.detector, rate_hz, gravity=gravity_det, gyro_bias_b=bias_det)
        self._sat = np.zeros(0, np.uint8)
        cue = self.settings.detector.with_method("shoe", min_stance_s=self.live.cue_min_stance_s)
        self._cue = StreamStance(cue, rate_hz, gravity=gravity_det, gyro_bias_b=bias_det)
        self._cue_prev = False  # the cue's decision at the sample before its newest chunk
        self._recent = RecentSamples()
        self._bias = (self._nav.setup.acc_bias0_b, self._nav.setup.gyro_bias0_b)
        self.note = self._segment_note  # None, or what a new segment after a lost signal must say
        self._pending = got + ([None] if final else [])
        return True

    def _cue_push(self, c) -> None:
        """Feed the low-latency cue; a stance start it decides becomes a provisional row."""
        self._recent.push(c.t_s, c.acc_mps2, c.gyro_radps)
        for d in self._cue.push(c.t_s, c.acc_mps2, c.gyro_radps, c.saturated):
            s = np.asarray(d.stance, bool)
            self._recent.mark(d.start, s)
            onsets = np.flatnonzero(s & ~np.concatenate(([self._cue_prev], s[:-1])))
            self._cue_prev = bool(s[-1]) if len(s) else self._cue_prev
            for k in (d.start + onsets).tolist():
                if k > 0:  # the initial rest is the start footprint, not a stride
                    self._provisional_at(k)
        self._recent.trim(self._nav.last_index + 1)

    def _provisional_at(self, k: int) -> None:
        """A provisional row at absolute sample ``k`` (a stance start): the filtered state dead-reckoned to it."""
        nav = self._nav
        last = nav.last_index
        if last < 0:
            return
        t, acc, gyro, still = self._recent.between(last + 1, k + 1)
        if last >= k or not len(t):
            pos = nav.position_n
            t_k = float(nav.last_t_s) if last >= k else float("nan")
        else:
            ba, bg = (np.asarray(b, float) for b in self._bias)
            pos = propagate_position(nav.position_n, nav.velocity_n, nav.q_nb, ba, bg, float(nav.last_t_s), t, acc,
                                     gyro, still, nav.gravity)
            t_k = float(t[-1])
        pos = np.asarray(pos, float) + self._offset_n + np.array([0.0, 0.0, self._z_storey])  # on the storeys too
        if not (np.isfinite(t_k) and t_k > self._covered_t):
            return
        ref = np.asarray(self._prov[-1][1:4], float) if self._prov else self._last_kept
        if ref is not None and np.linalg.norm(pos - ref) < self.min_stride_m:
            return  # a weight shift, not a stride (``strides.stride_footprints``)
        self._prov.append([t_k, float(pos[0]), float(pos[1]), float(pos[2]), int(self._level)])

    def _motion(self, t_s: np.ndarray, stance: np.ndarray) -> None:
        """Newest decided sample and newest moving (not stance) sample."""
        if len(t_s):
            self._t_latest = float(t_s[-1])
            moving = np.flatnonzero(~np.asarray(stance, bool))
            if moving.size:
                self._t_motion = float(t_s[moving[-1]])

    # ------------------------------------------------------------------ geometry
    def _final_rows(self, t_s: np.ndarray, pos_n: np.ndarray, stance: np.ndarray) -> list[list[float]]:
        """Footprints closed by the new final rows; a stance phase whose rows are all final is closed as soon
        as the next sample is decided to be a swing (its row waits for the smoother: a stride later)."""
        self._fp.push(t_s, pos_n, stance)
        closed = len(self._ahead) and not self._ahead[0]
        if closed:
            self._fp.finish()  # closes the open stance phase; the accumulator goes on with the next rows
        if len(t_s) and (closed or not stance[-1]):
            self._covered_t = float(t_s[-1])  # every stance phase up to here is closed
            self._prov = [r for r in self._prov if r[0] > self._covered_t]
        return self._add_footprints(*self._new_footprints())

    def _new_footprints(self) -> tuple[np.ndarray, np.ndarray]:
        """The footprints the accumulator closed since the last call: mid times (K,), positions (K, 3)."""
        k0, self._n_fp = self._n_fp, len(self._fp.t_mid)
        return np.asarray(self._fp.t_mid[k0:], float), np.asarray(self._fp.fp[k0:], float).reshape(-1, 3)

    def _add_footprints(self, t_fp: np.ndarray, fp: np.ndarray) -> list[list[float]]:
        """Floors of every footprint; rows for those that end a stride (``strides.stride_footprints``)."""
        if len(fp) == 0:
            return []
        fp = fp + self._offset_n
        fp_raw = fp.copy()  # as the filter gave them (the storeys' input)
        if self._z0 is None:
            self._z0 = float(fp[0, 2])
        if self._dirs is not None:
            if self._dirs.push(fp[:, :2]) and self._nav is not None:
                self._nav.enable_heading_aid(self._dirs.reference_rad)
                self.note = (f"heading aid on from stride {self._dirs.decided_at_stride}: the strides follow a "
                             f"building's axes ({math.degrees(self._dirs.reference_rad):.0f} deg)")
            if self._dirs.on and self._nav is not None and self.settings.filter.heading_aid_segments:
                self._nav.set_heading_gate(self._dirs.gate_open)  # per segment: the latest leg on the grid
        z_rel = fp[:, 2] - self._z0
        if self.floors.storeys:  # the storeys' rules on the footprints so far (causal: nothing after them)
            levels = np.zeros(len(fp), np.int64)
            for k in range(len(fp)):
                fp[k, 2], levels[k] = self._storey(fp_raw[:k + 1])
            z_rel = fp[:, 2] - self._z0
            self._fp_last_z, self._level = float(z_rel[-1]), int(levels[-1])
            self._z_storey = float(fp[-1, 2] - fp_raw[-1, 2])
        else:
            seg = floor_signal(np.concatenate(([self._fp_last_z], z_rel)), self.floors)
            signal = seg[1:] - seg[0] + self._signal_last
            h = self.floors.floor_height_m
            levels = floor_levels(signal - self._level * h, self.floors) + self._level
            self._fp_last_z, self._signal_last, self._level = float(z_rel[-1]), float(signal[-1]), int(levels[-1])
        if self._last_kept is None:
            keep = stride_footprints(fp, self.min_stride_m)
        else:
            keep = stride_footprints(np.vstack((self._last_kept, fp)), self.min_stride_m)[1:] - 1
        self._fp_seen.append(fp_raw)
        rows = []
        k0 = self._n_fp - len(fp)  # index of fp[0] among all footprints
        n_cov = max(0, min(len(fp), len(self._ends_cov) - k0))  # phases with a covariance (all, in step)
        if self._scale_cov is None:
            self._scale_cov = ScaleErrorAccumulator(*scale_sigmas(
                self.settings, self.calibration is not None and self.calibration.calibration is not None))
        extra = self._scale_cov.push(fp[:n_cov], np.asarray(self._ends_yaw[k0:k0 + n_cov], float))
        for k in keep.tolist():
            if self._last_kept is not None:
                self._distance_m += float(np.hypot(*(fp[k, :2] - self._last_kept[:2])))
            self._last_kept = fp[k]
            a = b = o = None  # (no covariance: cannot happen while rows and phases stay in step)
            if k < n_cov:
                a, b, o = (float(v) for v in ellipse(*(np.asarray(self._ends_cov[k0 + k]) + extra[k])))
            rows.append([float(t_fp[k]), float(fp[k, 0]), float(fp[k, 1]), float(fp[k, 2]), int(levels[k]), a, b, o])
        self._rows.extend(rows)
        return rows

    def _storey(self, fp_new: np.ndarray) -> tuple[float, int]:
        """Height and storey number of the last of ``fp_new`` (this push's footprints up to it) by the storeys'
        rules (``floors.storey_offsets``) on every footprint so far: the same rules as ``process``, causal (a
        flight's landing corrects what follows it, never what was shown). K footprints: one pass per stride
        shown, O(K) each (≈ 10 ms after an hour's 3600 strides, once a second)."""
        from bootnav.postproc.floors import storey_offsets

        all_fp = np.vstack(self._fp_seen + [fp_new])
        fs, f = self.floors, self.settings.filter
        res = storey_offsets(all_fp, f.level_max_dz_m, fs.riser_min_m, fs.riser_max_m, f.level_min_stride_m,
                             fs.hysteresis_m, fs.floor_height_m)
        return float(all_fp[-1, 2] + res.offset_fp[-1]), int(res.storey_fp[-1])

    # ------------------------------------------------------------------ out
    def status(self, wall_s: float, ended: bool) -> dict:
        """What the boot's panel shows (JSON-ready)."""
        since = self._t_motion if self._t_motion is not None else self._t_start
        still = float(self._t_latest - since) if since is not None and np.isfinite(self._t_latest) else 0.0
        if self._wall0 is None:
            self._wall0 = wall_s
        link = self.link.as_dict(wall_s, ended)
        # a silent boot: the wall time without samples adds to the time without (known) motion (module docstring)
        lost = not ended and link["state"] in ("waiting", "stale", "disconnected")
        silent = (link["age_s"] if link["age_s"] is not None else wall_s - self._wall0) if lost else 0.0
        still = max(still, 0.0) + silent
        alarm = bool(still >= self.live.no_motion_s)
        last = self._rows[-1] if self._rows else None
        return {"floor": self._level, "height_m": self._fp_last_z, "distance_m": self._distance_m,
                "uncertainty_m": [last[5], last[6]] if last and last[5] is not None else None,
                "strides": max(len(self._rows) - 1, 0), "still_s": still, "alarm": alarm,
                "alarm_reason": ("signal lost" if lost else "no motion") if alarm else None,
                "t_s": self._t_latest if np.isfinite(self._t_latest) else 0.0, "link": link, "note": self.note}

    def result(self) -> dict:
        """The final stride rows and figures (``live.json``)."""
        return {"columns": list(ROW_COLUMNS), "rows": self._rows,
                "distance_m": self._distance_m, "strides": max(len(self._rows) - 1, 0), "final_floor": self._level,
                "height_m": self._fp_last_z, "note": self.note,
                "heading_aid_from_stride": None if self._dirs is None or not self._dirs.on else
                self._dirs.decided_at_stride,
                "heading_aid_segments": None if self._dirs is None or not self.settings.filter.heading_aid_segments
                else dict(self._dirs.segments),
                "link": {k: v for k, v in self.link.as_dict(0.0, True).items() if k != "age_s"}}
