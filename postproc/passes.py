"""The passes over the blocks of one input window (``BlockPasses``) that ``pipeline.process_to`` (what ``bootnav
process`` runs) and ``pipeline.process`` (the API, ``eval``, two boots) run; the final pass's sinks (one
``push(rows)`` / ``close()`` each: trajectory.csv, results.h5, the charts, a reference's rows, or ``process``'s
rows in memory); and the accumulators the passes take their whole-record decisions with. The passes in order,
and why passes: ``pipeline``'s docstring.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from bootnav.core import atomic
from bootnav.errors import InputError

from .checks import (ClipRails, StepWarnings, check_path_finite, check_samples, join_saturation_intervals,
                     refuse_fatal, saturation_intervals, saturation_warnings, stride_findings)
from .passcache import PassSpills
from .settings import ProcessSettings


def block_rows(t_head: np.ndarray, block_s: float) -> int:
    """Samples per block: ``block_s`` seconds at the nominal period (median step of the first samples)."""
    dt0 = float(np.median(np.diff(t_head))) if len(t_head) > 1 else 1.0
    if not (dt0 > 0 and np.isfinite(dt0)):
        return max(len(t_head), 2)  # time not increasing: the checks of ``process`` name it
    return max(int(round(block_s / dt0)), 2)



class BlockPasses:
    """The passes over the blocks of one input window (module docstring): what ``process_to`` and ``process`` run.

    One method per pass, named for what it decides, in the order ``run`` calls them; the state they share (the
    input, the settings, the blocks and their spills, Δt₀, the clipping rails, the initial alignment, the noise
    floor, the chosen stance, the decisions of each pass) is held here.

    Parameters
    ----------
    run : pipeline._Input
        What the passes read and where their results go.
    settings : ProcessSettings
        Validated settings.
    out : Path or None
        The output folder; None: the final pass keeps its rows in ``run.rows`` (``pipeline._Collected``), writing nothing.
    warnings : list of str
        The run's warnings so far; the passes add theirs to this list (the summary's ``warnings``).
    lap : pipeline._StageClock
        Called at the end of each pass (``summary["timings_s"]``).
    worker : outputs.ChartWorker or None
        The chart process (None: the charts, if any, are drawn here).
    progress : callable or None
        ``progress(stage, fraction)``.

    Attributes
    ----------
    blocks : list of (int, int)
        The rows of each block; ``spills`` (``passcache.PassSpills``) what the passes read back over many.
    dt0, gravity, init, rails
        Δt₀ (s), gravity (m/s²), the initial alignment, the clipping rails (None without clipping detection).
    floor, chosen
        The adaptive detector's noise floor (log10, None for another detector); the fallback's stance ({}: the
        configured detector's).
    period, tau, timing, failed
        The gait period (s), the timing offset τ (s) and its figures, why the configured stance failed (None).
    final_filter, gate_iv, revisit, storeys
        The pass-3 decisions the final pass runs with: the filter (aided or not), the heading gate, the
        revisits' corrections, the storeys' offsets.
    """

    def __init__(self, run, settings: ProcessSettings, out: Path | None, warnings: list[str], lap, worker,
                 progress: Callable[[str, float], None] | None):
        self.input, self.settings, self.out, self.warnings = run, settings, out, warnings
        self.lap, self.worker, self.progress = lap, worker, progress
        self.name, self.rec = run.name, run.rec
        self.chosen: dict = {}  # the fallback's stance: "detector" (settings, floor) or "cycle" (the mask); {}: configured
        self.fallback = None  # the fallback chosen when the configured detector failed (``select_fallback``)
        self.rails = None
        self._last_read: dict = {}  # one block: its rows, calibrated, decoded once for all the passes

    def run(self) -> tuple[dict, dict[str, str]]:
        """Every pass in order; (summary, files: {} when ``out`` is None)."""
        import tempfile

        from . import selftune

        self.open_window()
        self.clipping_rails()
        self.check_samples_pass()
        self.initial_alignment()
        self.lap("load")
        self.floor = None
        if self.settings.detector.method == "adaptive":  # pass 1: the noise floor F over the whole recording
            self.floor = self.noise_floor(self.settings.detector)
        self.lap("stance_floor")
        self.rate_rows = tempfile.TemporaryFile(prefix="bootnav-rate-")  # ‖ω‖ per sample (8 B each), from pass 2
        st = self.settings.selftune
        for attempt in range(2):  # the passes again with the fallback's stance when the configured one failed
            self.timing_pass(attempt)
            if attempt == 0:
                self.configured_stance_findings()
            self.lap("timing")
            if attempt == 0 and self.failed is not None:  # a fatal stance finding: the fallback's passes
                self.fallback = self.select_fallback(self.failed, self.period)
                self.warnings += self.fallback["warnings"]
                self.lap("fallback")
                continue
            self.path_decisions()
            sinks = _FinalSinks(self)
            try:
                path = self.final_pass(sinks)
                self.strides_pass(path)
                if attempt == 0 and self.failed is None and self.quality.bad_fraction > st.max_bad_fraction:
                    self.failed = selftune.implausible_strides(self.quality)
                    if st.fallback:  # the configured path's strides fail: the fallback's passes
                        del self.warnings[self.n_warn:]
                        self.fallback = self.select_fallback(self.failed, self.period)
                        self.warnings[self.n_warn:self.n_warn] = self.fallback["warnings"]
                        self.lap("fallback")
                        continue
                    self.warnings.insert(self.n_warn, f"stance detector '{self.settings.detector.method}': "
                                                      f"{self.failed}")
                self.stride_checks(path)
                summary = self.summary(path)
                if self.input.rows is not None:  # ``process``: the run's figures beside its rows
                    self.input.rows.extra.update(
                        init=self.init, gravity=float(self.gravity), sensor_cal=self.sensor_cal,
                        saturation_intervals=self.sat_iv, steps=self.steps, metrics=self.metrics,
                        period=float(self.period), quality=self.quality, timing=self.timing,
                        confidence=float(self.confidence), choice=self.choice, failed=self.failed,
                        candidates=self.fallback["candidates"] if self.fallback else [], threshold=self.threshold,
                        stance_info=summary["stance"]["info"], filter_info=summary["filter"])
                    break
                files = self.write_files(path, sinks, summary)
            finally:
                sinks.close()
            break
        self.rate_rows.close()
        return summary, ({} if self.out is None else files)

    # -- load: the window, Δt₀, the blocks, the clipping rails, the sample checks, the initial alignment ---------

    def open_window(self) -> None:
        """The window's extent, its sensor calibration, Δt₀ and its blocks; refuses fewer than 3 samples."""
        from .calibration import resolve_calibration

        rec, settings = self.rec, self.settings
        self.device = rec.meta.get("device")
        self.sensor_cal = resolve_calibration(settings.calibration, rec.meta.get("device_id"), self.input.calibration)
        self.warnings += self.sensor_cal.warnings
        n = self.n = rec.n
        self.t_first, self.t_last = (float(rec.times(i, i + 1)[0]) for i in (0, n - 1)) if n else (0.0, 0.0)
        if n < 3:
            raise InputError(f"{self.name}: only {n} samples; nothing to process")
        rec.check_units()
        cal = settings.calibration
        self.gravity = cal.gravity()
        t_head = rec.times(0, min(n, 1 << 16))
        try:
            self.dt0 = _nominal_period(rec)  # the whole record's, as ``process`` takes it (``timebase.sample_period``)
        except ValueError:  # no positive step: the checks below refuse the record
            self.dt0 = float(np.median(np.diff(t_head)))
        rows = block_rows(t_head, settings.block_s)
        self.n_init = int(min(n, max(rows, np.searchsorted(t_head, t_head[0] + cal.still_search_s + cal.max_still_s
                                                               + 1.0) + 1)))
        self.blocks = [(i, min(n, i + rows)) for i in range(0, n, rows)]
        self.spills = PassSpills(self.blocks)  # many blocks: decoded, stance and filter rows computed once (``passcache``)

    def read(self, i0: int, i1: int):
        """Rows i0..i1-1 of the window: (t, acc, gyro, saturation bits), calibrated, the clipping rails' bits added."""
        from .calibration import apply_calibration

        last_read, spills, rails = self._last_read, self.spills, self.rails
        if last_read.get("rows") == (i0, i1):
            t, acc, gyro, sat = last_read["block"]
        elif (kept := spills.samples.get(i0, i1)) is not None:  # decoded and calibrated by an earlier pass
            t, acc, gyro, sat = kept
        else:
            t, acc, gyro, sat = self.rec.block(i0, i1)
            if self.sensor_cal.calibration is not None:
                acc, gyro = apply_calibration(self.sensor_cal, acc, gyro, self.rec.temp_degc(i0, i1))
                self.warnings.extend(w for w in self.sensor_cal.warnings if w not in self.warnings)
            if len(self.blocks) == 1:  # more blocks: none is read twice in a row, and keeping one adds to the peak
                for a in (t, acc, gyro, sat):  # shared by the passes: a stage that wrote into them fails here
                    a.flags.writeable = False
                last_read.update(rows=(i0, i1), block=(t, acc, gyro, sat))
            spills.samples.put(i0, i1, (t, acc, gyro, sat))
        if rails is not None and rails.rail_pos is not None:
            sat = spills.samples.railed(i0, i1, lambda: sat | self._rail_bits(i0, i1, acc, gyro))
        return t, acc, gyro, sat

    def _rail_bits(self, i0: int, i1: int, acc, gyro):
        """The clipping rails' bits of rows i0..i1-1, found on the samples as the sensor gave them: it clips in its
        own units, and a calibration's scale and cross-axis terms would make an exact rail slope."""
        if self.sensor_cal.calibration is not None:
            _, acc, gyro, _ = self.rec.block(i0, i1)
        return self.rails.bits(acc, gyro)

    def read_raw(self, i0: int, i1: int):
        """Rows i0..i1-1 as the sensor gave them (no calibration), the clipping rails' bits added once they are
        known: what the rails and the sample checks look at, as ``_rail_bits`` says."""
        if self.sensor_cal.calibration is None:
            return self.read(i0, i1)
        t, acc, gyro, sat = self.rec.block(i0, i1)
        if self.rails is not None and self.rails.rail_pos is not None:
            sat = sat | self.rails.bits(acc, gyro)
        return t, acc, gyro, sat

    def clipping_rails(self) -> None:
        """The extremes of the whole record, then the samples at them (``checks.ClipRails``)."""
        if self.settings.detector.detect_clipping:
            self.rails = ClipRails(self.settings.filter.sloping_rails)
            for i0, i1 in self.blocks:
                self.rails.add_peaks(*self.read_raw(i0, i1)[1:3])
            for i0, i1 in self.blocks:
                self.rails.add_counts(*self.read_raw(i0, i1)[1:3])
            self.rails.finish()

    def check_samples_pass(self) -> None:
        """The checks of ``process`` (refusals per block; the warnings of the whole record's steps, first) and the
        saturated bursts joined across blocks (``sat_iv``)."""
        settings, name, t_first, t_last = self.settings, self.name, self.t_first, self.t_last
        duration = t_last - t_first
        if duration < settings.checks.min_duration_s:  # as check_samples refuses it
            raise InputError(f"{name}: too short: {duration:.2f} s of data (need >= {settings.checks.min_duration_s:g}"
                             " s: a still period plus a few strides)")
        step_checks = StepWarnings(self.dt0)  # the warnings of ``check_samples`` on the whole record's steps
        sat_iv: list[dict] = []
        start = self.rec.start
        for i0, i1 in self.blocks:  # the checks of ``process`` (each block with the last samples of the one before)
            a = max(i0 - 2, 0)
            t, acc, gyro, sat = self.read_raw(a, i1)
            check_samples(name, t, acc, gyro, start + a, settings.checks, (t_first, t_last))  # refusals; warnings
            # of the whole record below
            k = max(i0 - a - 1, 0)  # the steps that end in this block
            step_checks.push(t[k:-1], np.diff(t[k:]))
            sat_iv = join_saturation_intervals(sat_iv, saturation_intervals(t[i0 - a:], sat[i0 - a:], start + i0))
        self.warnings[:0] = step_checks.warnings() + saturation_warnings(sat_iv)  # first, as ``process`` orders them
        self.sat_iv = sat_iv

    def initial_alignment(self) -> None:
        """Roll, pitch and gyro bias from the first seconds (with Δt₀), and the stance detector's references."""
        from .calibration import initial_alignment, stance_reference
        from .summary import alignment_summary

        t0_, a0_, g0_, _ = self.read(0, self.n_init)
        self.init = initial_alignment(t0_, a0_, g0_, self.settings.calibration, self.gravity, dt_s=self.dt0)
        self.warnings += list(self.init.warnings)
        self.alignment = alignment_summary(self.init, self.gravity, t0_)
        self.rate = 1.0 / self.dt0
        self.bias_det, self.gravity_det = stance_reference(self.init, self.gravity)  # as ``navigate`` gives the detector
        self.probe_detector = self.settings.detector.build(self.gravity_det)

    # -- the stance: the detector's chunks, the noise floor, the fallback ----------------------------------------

    def detector_stream(self, det_settings, det_floor):
        """StanceChunks of a detector over the blocks (replayed when an earlier pass spilled them)."""
        from .detectors.stream import stance_detector

        replayed = self.spills.stance.replay(det_settings, det_floor)  # the chunks an earlier pass spilled
        if replayed is not None:
            yield from replayed
            return
        det = stance_detector(det_settings, self.rate, self.gravity_det, noise_floor_log10=det_floor,
                              gyro_bias_b=self.bias_det)
        keep = self.spills.stance.recorder(det_settings, det_floor).keep
        for i0, i1 in self.blocks:
            yield from keep(det.push(*self.read(i0, i1)))
        yield from keep(det.finish(), last=True)

    def stance_stream(self):
        """Yield StanceChunks of the whole recording (fixed floor: the same for every chunking): the configured
        detector's, their stance the fallback's when one was chosen (the statistic stays the configured one's,
        as ``process`` keeps it)."""
        configured = self.settings.detector
        if "cycle" in self.chosen:
            for ch in self.detector_stream(configured, self.floor):
                ch.stance = ch.stance | self.chosen["cycle"][ch.start:ch.start + len(ch)]
                yield ch
        elif "detector" in self.chosen:
            yield from _with_stance_of(self.detector_stream(configured, self.floor),
                                       self.detector_stream(*self.chosen["detector"]))
        else:
            yield from self.detector_stream(configured, self.floor)

    def noise_floor(self, det_settings) -> float:
        """The adaptive detector's noise floor F over the whole recording (pass 1)."""
        from .detectors.stream import StreamStance

        det = det_settings.build(self.gravity_det)
        probe = StreamStance(det_settings, self.rate, self.gravity_det, gyro_bias_b=self.bias_det)
        lowest = _LowestValues(det.noise_quantile, self.n)
        for i0, i1 in self.blocks:
            for ch in probe.push(*self.read(i0, i1)):
                lowest.add_chunk(ch, det.rest_floor())
        for ch in probe.finish():
            lowest.add_chunk(ch, det.rest_floor())
        low = lowest.quantile()
        return probe.noise_floor_log10 if low is None else low  # all excluded (saturated): the stream's

    def rate_p99(self) -> float:
        """‖ω‖'s 99th percentile over the record (``summary.mount_check``'s), exact from the spilled rows."""
        return _percentile(lambda: _spilled(self.rate_rows, self.n), 99)

    def select_fallback(self, failed: str, period: float) -> dict:
        """The stance fallback in passes: ``selftune``'s candidates scored by forward runs
        over the blocks, the no-rest and mount rules; sets ``chosen``; returns choice, candidates, no_rest
        and the warnings."""
        from bootnav.core.arrays import row_norm

        from .summary import mount_check_of

        settings, init, n, floor = self.settings, self.init, self.n, self.floor
        st_ = settings.selftune
        name0 = f"configured ({settings.detector.method})"
        specs = [(name0, settings.detector, floor)]
        for a in st_.alphas:
            ds = settings.detector.with_method("adaptive", alpha=a)
            specs.append((f"adaptive alpha={a:g}", ds, self.noise_floor(ds)))
        if st_.shoe_threshold:
            specs.append((f"shoe {st_.shoe_threshold:g}", settings.detector.with_method(
                "shoe", threshold=st_.shoe_threshold), None))
        rows = [_CandidateScore(nm, init, self.gravity, self.dt0, settings.filter).run(
            ((ch, ch.stance) for ch in self.detector_stream(ds, fl)), period, st_, n) for nm, ds, fl in specs]
        cyc = _cycle_minimum(self.detector_stream(settings.detector, floor), n, self.bias_det, self.gravity_det,
                             period, settings)
        if cyc is not None:
            rows.append(_CandidateScore("cycle minimum", init, self.gravity, self.dt0, settings.filter).run(
                ((ch, ch.stance | cyc[ch.start:ch.start + len(ch)])
                 for ch in self.detector_stream(settings.detector, floor)), period, st_, n))
        best = int(np.argmin([r["J"] for r in rows]))
        chosen_row = rows[best]
        sel_warnings = ["no periodic gait found (autocorrelation of |ω| below 0.2 at 0.4-3 s)"] \
            if not np.isfinite(period) else []
        sel_warnings.append(f"stance detection: the configured detector fails ({failed}); fallback "
                            f"'{chosen_row['name']}' chosen (criterion {chosen_row['J']:.3f} m/s vs "
                            f"{rows[0]['J']:.3f} m/s)")
        for r in rows:
            r.pop("_q", None)
        pick = {}
        if chosen_row["name"] == "cycle minimum":
            pick["cycle"] = cyc
        elif best > 0:
            pick["detector"] = specs[best][1:]
        self.chosen.clear()
        self.chosen.update(pick)
        # the median turning rate at rest of the chosen mask (exact, ``_order_statistics``)
        g0 = np.asarray(init.gyro_bias_b)
        rates = lambda: (row_norm(ch.gyro_b[ch.stance] - g0) for ch in self.stance_stream())  # noqa: E731
        m = sum(len(v) for v in rates())
        rate_ = float(np.mean(_order_statistics(rates, ((m - 1) // 2, m // 2)))) if m else np.inf
        gait_txt = ("no periodic gait" if not np.isfinite(period)
                    else f"a gait period of {period:.2f} s but no moment the foot rests")
        if not any(np.isfinite(r["J"]) for r in rows) or rate_ > st_.fail_stance_rate_radps:
            p99_ = self.rate_p99()
            mount_ = mount_check_of(p99_, self.t_last - self.t_first, period, 0.0)
            if not mount_["looks_like_foot"] or not np.isfinite(period):
                why = (mount_["message"] if not mount_["looks_like_foot"] else
                       "a moving foot rests once per stride and repeats its stride: this signal does neither")
                raise InputError(f"{self.name}: not a walking foot: {failed}; no other stance detection finds a "
                                 f"zero-velocity phase either ({gait_txt}), and {why}")
            self.chosen.clear()
            return {"choice": name0, "candidates": rows, "no_rest": True, "warnings": [
                f"no stance detection finds a zero-velocity phase ({failed}; {gait_txt}): the path is mostly "
                "unaided inertial integration and its confidence is 0; check that the sensor is on the foot"]}
        return {"choice": chosen_row["name"], "candidates": rows, "no_rest": False, "warnings": sel_warnings}

    # -- pass 2: the gait period, the timing calibration, the stance findings -------------------------------------

    def timing_pass(self, attempt: int) -> None:
        """The gait period, and the forward filters of the timing calibration (two probes at ±δ) or, with it off,
        the one forward run that scores the path (the RMS of its ZUPT-onset innovations,
        ``selftune.onset_innovations``); the stance phases and ‖ω‖ at rest for the stance findings."""
        from bootnav.core.arrays import row_norm

        from . import selftune
        from .ins.filter import navigator

        settings, init, gravity, dt0, n = self.settings, self.init, self.gravity, self.dt0, self.n
        st = settings.selftune
        timing: dict = {}
        tau = 0.0
        signs = (-1, 1) if st.timing_calibration else (0,)
        probe_filter = replace(settings.filter, smoother="none", level_height=False)  # as selftune's probes
        forward = probe_filter if st.timing_calibration else replace(settings.filter, smoother="none")
        probes = _ForwardProbes({s: navigator(init, gravity, dt0, forward) for s in signs},
                                st.timing_probe_s, st.timing_max_level_strides if st.timing_calibration else None)
        gait = selftune.GaitPeriodAccumulator(dt0)
        phase_starts = _Runs()  # the stance phases
        stance_rate = _LogHistogram()  # ‖ω‖ over the stance samples (``checks.stance_findings``)
        n_stance_all = 0
        for ch in self.stance_stream():
            gait.push(ch.gyro_b)
            if attempt == 0:  # ‖ω‖ of every sample, for the mount check's percentile
                np.linalg.norm(ch.gyro_b, axis=1).tofile(self.rate_rows)
            phase_starts.push(ch.start, ch.stance)
            stance_rate.add(row_norm(ch.gyro_b[ch.stance]))
            n_stance_all += int(np.count_nonzero(ch.stance))
            probes.push(ch, phase_starts.starts)
        self.period = gait.finish()
        fp_probe, cut, onsets = probes.finish(phase_starts.starts, n)
        if st.timing_calibration:
            cap = {"max_level_strides": st.timing_max_level_strides}  # the whole run's rule (level_timing_offset)
            timing["m_minus"], n_level = selftune.footprint_level_dz(*fp_probe[-1], **cap)
            timing["m_plus"], timing["n_level"] = selftune.footprint_level_dz(*fp_probe[1], **cap)
            timing["innovation_rms_mps"] = float(np.sqrt(np.mean([onsets[s].mean_square(cut) for s in signs])))
            timing["probe_s"] = float(self.rec.times(cut - 1, cut)[0] - self.t_first)
            timing = selftune.timing_from_probes(timing, st.timing_probe_s, st.timing_max_abs_s,
                                                 st.timing_min_level_strides)
            tau = timing["tau_s"]
            self.innovation = timing["innovation_rms_mps"]
        else:
            self.innovation = float(np.sqrt(onsets[0].mean_square(n)))
        del probes, fp_probe, onsets
        self.timing, self.tau, self.phase_starts = timing, tau, phase_starts
        self._stance_rates = (n_stance_all, stance_rate)

    def configured_stance_findings(self) -> None:
        """The configured detector's mask judged (``checks.stance_findings_of``): ``failed`` (None: it is kept);
        refused when it fails and the fallback is off."""
        from .checks import stance_findings_of

        settings, n = self.settings, self.n
        n_stance_all, stance_rate = self._stance_rates
        findings = stance_findings_of(len(self.phase_starts.starts), n_stance_all / n, self.t_last - self.t_first,
                                      stance_rate.median() if n_stance_all else None, settings.checks,
                                      settings.detector.method)
        self.warnings += [f.message for f in findings if not f.fatal]
        fatal = [f.message for f in findings if f.fatal]
        self.failed = fatal[0] if fatal else None
        if self.failed and not settings.selftune.fallback:
            raise InputError(f"{self.name}: {self.failed}")
        self.n_warn = len(self.warnings)  # the warnings of the configured path start here

    # -- pass 3: the heading decision, the revisits, the storeys -----------------------------------------------

    def acc_used(self, ch):
        """The specific force the filter gets: rotated by the timing offset τ."""
        from . import selftune

        return selftune.rotate_specific_force(ch.acc_b, ch.gyro_b, self.tau) if self.tau else ch.acc_b

    def gate(self, ch):
        """The heading aid's per-sample gate of a chunk (None: the aid, if on, acts everywhere)."""
        from .building.directions import gate_of

        return None if self.gate_iv is None else gate_of(self.gate_iv, ch.start, ch.start + len(ch.t_s))

    def corrected(self, r):
        """The revisits' horizontal correction of the rows (``building.revisits.apply_revisits``' rule:
        the footprints' corrections interpolated in time), in place."""
        revisit = self.revisit
        if revisit is not None:
            r.pos_n = r.pos_n.copy()
            for ax in range(2):
                r.pos_n[:, ax] += np.interp(r.t_s, revisit[0], revisit[1][:, ax])
        return r

    def path_footprints(self, filter_settings, with_var=False):
        """A pass of the filter + smoother (its rows corrected by the revisits found): its footprints (mid
        times, (K,); (K, 3)) and, ``with_var``, the horizontal variance at their times (K,).

        With no revisit correction, the navigator of the pass and the rows of each of its pushes (in memory over
        one block, spilled over more: ``passcache.NavRowSpill``) are kept in ``replay``, which the final pass
        replays when it runs the same filter with the same gate (the heading decision off: the unaided path is
        the final one, as ``navigate`` runs it once)."""
        from .ins.filter import navigator
        from .strides import FootprintAccumulator

        path_nav = navigator(self.init, self.gravity, self.dt0, filter_settings)
        path_fp = FootprintAccumulator()
        var = _PhaseInterpolation() if with_var else None
        pieces = self.spills.nav_rows() if self.revisit is None else None  # one block: in memory; more: spilled
        self.replay.clear()

        def keep(r) -> None:
            r = self.corrected(r)
            path_fp.push(r.t_s, r.pos_n, r.stance)
            if var is not None:
                var.push(r.t_s, r.pos_sigma_n[:, 0] ** 2 + r.pos_sigma_n[:, 1] ** 2, r.stance)

        for ch in self.stance_stream():
            r = path_nav.push(ch.t_s, self.acc_used(ch), ch.gyro_b, ch.stance, ch.saturated, heading_gate=self.gate(ch))
            if pieces is not None:
                pieces.append(r)
            keep(r)
        r = path_nav.finish()
        if pieces is not None:
            pieces.append(r)
            if pieces.kept:
                self.replay.update(filter=filter_settings, gate=self.gate_iv, nav=path_nav, rows=pieces)
        keep(r)
        if var is not None:
            return (*path_fp.finish(), var.finish())
        return path_fp.finish()

    def path_decisions(self) -> None:
        """Pass 3: the heading decision, the revisits and the storeys, each a pass of a filter when it is on."""
        self.replay: dict = {}
        self.revisit, self.revisit_report = None, None  # the pose graph's (footprint times, corrections (K, 2))
        self.final_filter, self.gate_iv, self.heading_decision = self.settings.filter, None, None
        path_fp = self.heading_pass()
        path_fp = self.revisits_pass(path_fp)
        self.storeys_pass(path_fp)

    def heading_pass(self):
        """With ``heading_aid="auto"``, pass 3a: the decision on the unaided path (after τ); the footprints of that
        path when it is the final one (the storeys' input), else None."""
        from .building.directions import aided_settings, gate_intervals, heading_plan

        if self.settings.filter.heading_aid != "auto":
            return None
        path_fp = self.path_footprints(self.settings.filter)
        dec, ends, aided = heading_plan(path_fp[1][:, :2], self.settings.filter)
        self.heading_decision = dec.as_dict()
        if dec.on:
            self.final_filter = aided_settings(self.settings.filter, dec)
            self.gate_iv = None if aided is None else gate_intervals(self.phase_starts.stops(self.n), ends, aided)
            path_fp = None  # the storeys are on the aided path
        self.lap("heading")
        return path_fp

    def revisits_pass(self, path_fp):
        """With ``filter.revisits``, pass 3b: the pose graph over the final filter's strides; the footprints of
        the final path when no correction was found (the storeys' input), else None."""
        from .building.revisits import revisit_corrections

        if self.settings.filter.revisits == "none":
            return path_fp
        rt, rfp, rvar = self.path_footprints(self.final_filter, with_var=True)
        t_k, delta, self.revisit_report = revisit_corrections(rt, rfp, rvar, self.settings.filter)
        if delta is not None:
            self.revisit = (t_k, delta)
            path_fp = None  # the storeys are on the corrected path
        else:
            path_fp = (rt, rfp)
        self.lap("revisits")
        return path_fp

    def storeys_pass(self, path_fp) -> None:
        """The final filter's footprints (``path_fp`` when a pass before gave them), for the storeys' height
        offsets (``floors.storey_offsets``); ``snap``: the final pass corrects its heights."""
        from .floors import storey_offsets

        settings = self.settings
        floors = settings.floor_settings()
        self.storeys, self.storey_t = None, None
        if floors.storeys:
            self.storey_t, storey_fp = path_fp if path_fp is not None else self.path_footprints(self.final_filter)
            self.storeys = storey_offsets(storey_fp, settings.filter.level_max_dz_m, floors.riser_min_m,
                                          floors.riser_max_m, settings.filter.level_min_stride_m, floors.hysteresis_m,
                                          floors.floor_height_m)
            self.lap("storeys")
        self.snap = self.storeys is not None and len(self.storey_t) > 0 and bool(np.any(self.storeys.offset_fp))

    # -- the final pass, the strides, the summary, the files ---------------------------------------------------

    def final_pass(self, sinks: _FinalSinks) -> _FinalPath:
        """The final filter + smoother; each row pushed to the sinks when final (``_FinalPath.emit``)."""
        from .ins.filter import navigator

        replay, final_filter = self.replay, self.final_filter
        reuse = (bool(replay) and replay["filter"] is final_filter and replay["gate"] is self.gate_iv
                 and self.revisit is None)
        nav = replay["nav"] if reuse else navigator(self.init, self.gravity, self.dt0, final_filter)
        replayed = iter(replay.pop("rows")) if reuse else None
        path = _FinalPath(self, sinks, nav)
        with contextlib.ExitStack() as stack:
            if self.out is not None:  # trajectory.csv appears complete or not at all
                sinks.open_trajectory(stack.enter_context(atomic.replacing(self.out / "trajectory.csv")))
            for ch in self.stance_stream():
                path.push_samples(ch)
                path.emit(next(replayed) if replayed is not None else
                          nav.push(ch.t_s, self.acc_used(ch), ch.gyro_b, ch.stance, ch.saturated,
                                   heading_gate=self.gate(ch)))
                if self.progress is not None:
                    self.progress("navigation", min(0.99, (ch.start + len(ch)) / self.n))
            path.emit(next(replayed) if replayed is not None else nav.finish())
        self.lap("navigation")
        return path

    def strides_pass(self, path: _FinalPath) -> None:
        """The footprints' strides with their flags and ellipses, the confidence; refuses a path with no motion."""
        from . import selftune
        from .ellipses import scale_error_covariance, scale_sigmas
        from .strides import footprint_strides

        settings, st, period = self.settings, self.settings.selftune, self.period
        floors = settings.floor_settings()
        self.t_mid, fp = path.fp_acc.finish()
        self.fp = fp
        min_stride = st.min_stride_m
        quality = self.quality = path.quality_acc.finish(period, st)
        self.confidence = selftune.confidence(self.innovation, quality.bad_fraction, period, st)
        split = selftune.split_strides(quality, period, st)
        if split:
            self.warnings.append(split)
        if not np.isfinite(period):
            self.warnings.append("no periodic gait found: the confidence of this path is 0")
        cov_h = path.fp_acc.cov.copy() if len(path.fp_acc.cov) == len(fp) else None
        path.yaw_acc.finish()
        if cov_h is not None and len(path.yaw_acc.cov) == len(fp):  # the sensor errors the filter does not model
            cov_h = cov_h + scale_error_covariance(fp, path.yaw_acc.cov[:, 0], *scale_sigmas(
                settings, self.sensor_cal.provenance.get("status") == "applied"))
        # the floor number: the storeys found as heights of whole nominal storeys (as ``process``)
        self.floor_z = self.storeys.storey_fp * floors.floor_height_m if self.storeys is not None else None
        self.steps = footprint_strides(self.t_mid, fp, min_stride, quality.flags & np.uint8(0xFF ^ selftune.TINY),
                                       floors, cov_h, self.floor_z)
        if len(self.steps["t_s"]) == 0 and not np.isfinite(period):
            raise InputError(f"{self.name}: no motion: not one stride of >= {min_stride:g} m and no periodic gait in "
                             f"{self.t_last - self.t_first:.1f} s; nothing to navigate (is the sensor on a walking "
                             "foot?)")

    def stride_checks(self, path: _FinalPath) -> None:
        """The stance choice, the stride findings, the path's figures; the mount check, the detector's threshold
        and, with a reference, its metrics."""
        from .reference_path import compute_metrics
        from .strides import footprint_summary
        from .summary import mount_check_of

        settings, warnings, fallback = self.settings, self.warnings, self.fallback
        floors = settings.floor_settings()
        min_stride = settings.selftune.min_stride_m
        self.choice = fallback["choice"] if fallback else f"configured ({settings.detector.method})"
        if fallback and fallback["no_rest"]:
            self.confidence = 0.0
        findings = stride_findings(self.steps, settings.checks, self.choice)
        warnings += ([f.message for f in findings] if settings.selftune.fallback else refuse_fatal(self.name, findings))
        self.path_stats = footprint_summary(self.fp, floors, min_stride, path.fp_acc.walked_s, self.floor_z)
        self.path_stats["storeys"] = self.storeys.summary() if self.storeys is not None else None
        self.lap("strides")
        p99 = self.rate_p99()
        self.mount = mount_check_of(p99, self.t_last - self.t_first, self.period,
                                    float(self.path_stats.get("distance_m", 0.0)))
        if not self.mount["looks_like_foot"]:  # as ``summary.build_summary``
            warnings.append(self.mount["message"])
        self.threshold = path.gamma.threshold(getattr(self.probe_detector, "threshold", None))
        self.metrics = None
        if path.sinks.reference is not None:  # as ``process``: the path with its storeys, every row
            path_rows = path.sinks.reference.rows(path.n_rows)
            self.metrics = compute_metrics(self.input.reference, path_rows[:, 0], path_rows[:, 1:4],
                                           path_rows[:, 4] > 0.5, self.rec.meta.get("mount"), min_stride)
            del path_rows
            self.lap("reference")

    def summary(self, path: _FinalPath) -> dict:
        """The run's summary (summary.json but ``files``; its schema in docs/)."""
        from bootnav.core.conventions import SOFTWARE
        from bootnav.core.jsonio import to_jsonable

        from . import selftune
        from .ins.measurements import LevelHeightMeasurement, ZaruMeasurement
        from .summary import HEADLINE_KEYS, PATH_CONVENTIONS, final_uncertainty, is_closed_loop

        settings, run, nav, final_filter = self.settings, self.input, path.nav, self.final_filter
        t_first, t_last, floor, quality, fallback = self.t_first, self.t_last, self.floor, self.quality, self.fallback
        gamma = path.gamma
        return {
            "input": {"source": self.name, "format": "hdf5" if run.is_hdf5 else "imported",
                      "samples_total": int(self.rec.reader.n), "samples_processed": path.n_rows,
                      "t_start_s": t_first, "t_end_s": t_last,
                      "crop_s": list(settings.crop_s) if settings.crop_s else None,
                      "duration_s": t_last - t_first, "rate_hz": float(self.rate),
                      "chunk_s": float(settings.block_s), "device": None if self.device is None else str(self.device),
                      "gravity_mps2": float(self.gravity)},
            "calibration": to_jsonable(self.sensor_cal.provenance),
            "alignment": self.alignment,
            "software": dict(SOFTWARE),
            "stance": {"method": settings.detector.method, "fraction": path.n_stance / max(path.n_rows, 1),
                       "phases": int(len(self.fp)), "noise_floor_log10": floor,
                       # a fixed-threshold detector's γ; the adaptive one's 10^median of its γ per sample
                       "threshold": to_jsonable(self.threshold),
                       # what the detector used (``detect_stance``'s info: the parts a run in passes knows)
                       "info": {"dt_s": float(self.dt0), "noise_floor_log10": floor, "n_saturated": path.n_saturated,
                                **({"threshold_log10_range": gamma.range} if gamma.n else {})}},
            "navigation": {"stance_choice": self.choice, "blocks": len(self.blocks),
                           "fallback_used": self.failed is not None and not self.choice.startswith("configured"),
                           "configured_failed": self.failed,
                           "candidates": to_jsonable(fallback["candidates"] if fallback else []),
                           "confidence": float(self.confidence), "gait_period_s": to_jsonable(float(self.period)),
                           "implausible_stride_fraction": to_jsonable(float(quality.bad_fraction)),
                           "stride_flags": {nm: int(np.count_nonzero(quality.flags & bit))
                                            for bit, nm in selftune.FLAG_NAMES.items()},
                           "stride_flag_bits": {nm: bit for bit, nm in selftune.FLAG_NAMES.items()},
                           "timing_offset": to_jsonable(self.timing)},
            "filter": to_jsonable({"mode": final_filter.mode, "engine": final_filter.engine,
                                   "n_states": final_filter.n_states, "smoother": final_filter.smoother,
                                   # which aids ran (as ``ins.run_filter`` says it)
                                   "zaru": ZaruMeasurement.active(final_filter),
                                   "heading_aid": final_filter.heading_aid,
                                   "level_height": LevelHeightMeasurement.active(final_filter),
                                   **nav.info,  # with the filter's (not smoothed) 1-σ of each error state at
                                   # the last sample, as ``ins.run_filter`` gives it
                                   "final_state_sigma": np.sqrt(np.maximum(np.diag(nav.covariance), 0.0)),
                                   **({} if self.heading_decision is None else
                                      {"heading_decision": self.heading_decision}),
                                   **({} if self.revisit_report is None else {"revisits": self.revisit_report})}),
            "path": self.path_stats,
            "metrics": to_jsonable(self.metrics),
            "saturation_intervals": self.sat_iv,
            "closed_loop": is_closed_loop(run.reference),
            "mount": self.mount,
            "uncertainty": final_uncertainty(self.steps),
            "confidence": float(self.confidence),
            **{k: self.path_stats[k] for k in HEADLINE_KEYS if k in self.path_stats},  # as ``summary.build_summary``
            "timings_s": self.lap.timings,
            "conventions": dict(PATH_CONVENTIONS),
            "settings": settings.to_dict(),
            "warnings": self.warnings,
        }

    def write_files(self, path: _FinalPath, sinks: _FinalSinks, summary: dict) -> dict[str, str]:
        """The outputs after the final pass (steps.csv, path.geojson, results.h5 committed, the charts); {kind: path}."""
        import json

        from .outputs import draw_here, geojson_of, write_steps_csv

        out, opts, charts, worker = self.out, self.settings.output, sinks.charts, self.worker
        if charts is not None:  # drawn by the chart processes while the files are finished
            charts.finish(self.t_mid, self.fp, self.steps, summary, self.settings)
            if worker is not None:
                worker.submit(charts, out)
        files = {"trajectory": str(out / "trajectory.csv")}
        files["steps"] = str(write_steps_csv(out / "steps.csv", self.steps))
        if opts.geojson and opts.geo_anchor:  # as ``outputs.write_outputs``
            atomic.write_text(out / "path.geojson", json.dumps(geojson_of(
                self.fp, path.ends[0], path.ends[1], summary.get("distance_m"), opts.geo_anchor)))
            files["geojson"] = str(out / "path.geojson")
        if sinks.results is not None:
            files["hdf5"] = sinks.results.commit(summary, self.steps, self.settings, self.rec.start,
                                                 self.sensor_cal.provenance)
        self.lap("write")
        if charts is not None:
            drawn, error = worker.wait() if worker is not None else draw_here(charts, out)
            if error:
                self.warnings.append(f"{out}: the charts were not drawn ({error}); the other outputs are complete")
            files.update(drawn)
            self.lap("plots")
        return files


class _FinalPath:
    """The final pass's rows as they become final (``emit``): checked finite, corrected by the revisits and the
    storeys, pushed to the sinks; and what the passes after it read: the footprints with their horizontal
    covariance, the unwrapped yaw at each phase's last sample (``ellipses``), the stride flags
    (``selftune.StrideQualityAccumulator``), the path's ends, its rows and stance samples, the saturated samples
    and the adaptive detector's γ (``_GammaLog``).

    Parameters
    ----------
    passes : BlockPasses
        The run (its revisits, storeys, name and window start).
    sinks : _FinalSinks
        Where the rows go.
    nav : ins.stream.StreamNavigator or ins.filterpy_engine.RecordReference
        The final filter (its ``info`` and ``covariance`` go to the summary).
    """

    def __init__(self, passes: BlockPasses, sinks: _FinalSinks, nav):
        from . import selftune
        from .strides import FootprintAccumulator

        self.passes, self.sinks, self.nav = passes, sinks, nav
        self.fp_acc = FootprintAccumulator()
        self.yaw_acc = FootprintAccumulator()  # the unwrapped yaw at each phase's last sample (``ellipses``)
        self._yaw_last: list[float] = []  # the previous row's unwrapped yaw: np.unwrap continued across blocks
        self.quality_acc = selftune.StrideQualityAccumulator()
        self._gyro_rows = _RowQueue()  # the gyro of the rows the navigator holds back, for the stride flags
        self._stat_rows = _RowQueue()  # the detector statistic of the rows the navigator holds back
        self.n_rows = self.n_stance = 0
        self.ends = [None, None]  # the path's first and last positions (the GeoJSON's start and end)
        self.n_saturated = 0  # samples the detector excluded as saturated (``detect_stance``'s ``n_saturated``)
        self.gamma = sinks.gamma

    def push_samples(self, ch) -> None:
        """A stance chunk before the navigator's rows of it: the samples the sinks and the stride flags need."""
        sinks = self.sinks
        if sinks.charts is not None:
            sinks.charts.push_imu(ch.t_s, ch.acc_b, ch.gyro_b, ch.saturated)
        self._gyro_rows.put(ch.start, ch.gyro_b)
        self.n_saturated += int(np.count_nonzero(np.any(np.reshape(ch.saturated, (len(ch), -1)), axis=1)))
        self.gamma.push(ch)
        if sinks.wants_statistic:
            self._stat_rows.put(ch.start, np.asarray(ch.statistic, np.float64))
        if sinks.collect is not None:
            sinks.collect.push_samples(ch, self.passes.acc_used(ch) if self.passes.tau else None)

    def emit(self, r) -> None:
        """Rows of the final filter (``NavRows``), final: corrected, accumulated, pushed to every sink."""
        from bootnav.core.rotations import euler_zyx_from_quat

        from .ellipses import unwrapped_yaw

        passes = self.passes
        if not len(r):
            return
        if not np.all(np.isfinite(r.pos_n)):
            check_path_finite(passes.name, r.t_s, r.pos_n, passes.rec.start + r.start)
        passes.corrected(r)
        self.quality_acc.push(r.t_s, r.pos_n, r.stance, self._gyro_rows.take(r.start, r.start + len(r)),
                              r.gyro_bias_b)  # on the filter's path, before the storeys
        pos_filter = r.pos_n  # the filter's path (revisits corrected), before the storeys
        if passes.snap:  # ``floors.snap_storeys``: the offsets interpolated in time between the footprints
            r.pos_n = r.pos_n.copy()
            r.pos_n[:, 2] += np.interp(r.t_s, passes.storey_t, passes.storeys.offset_fp)
        stat = self._stat_rows.take(r.start, r.start + len(r)) if self.sinks.wants_statistic else None
        self.sinks.push(_FinalRows(r, pos_filter, stat))
        self.fp_acc.push(r.t_s, r.pos_n, r.stance,
                         np.column_stack((r.pos_sigma_n[:, 0] ** 2, r.pos_sigma_n[:, 1] ** 2, r.pos_cov_en)))
        yaw = unwrapped_yaw(r.q_nb) if not self._yaw_last else np.unwrap(
            np.concatenate((self._yaw_last, euler_zyx_from_quat(np.asarray(r.q_nb, float))[:, 2])))[1:]
        self._yaw_last[:] = [float(yaw[-1])]
        self.yaw_acc.push(r.t_s, np.zeros((len(r), 3)), r.stance, np.column_stack((yaw, yaw, yaw)))
        if not self.n_rows:
            self.ends[0] = r.pos_n[0].copy()
        self.ends[1] = r.pos_n[-1].copy()
        self.n_rows += len(r)
        self.n_stance += int(np.count_nonzero(r.stance))


@dataclass
class _FinalRows:
    """One push of the final pass to its sinks: ``NavRows`` after the revisits' and the storeys' corrections, the
    filter's path before the storeys (``pos_filter``, (n, 3) m) and the detector statistic of the rows (None
    when no sink keeps it)."""

    r: Any
    pos_filter: np.ndarray
    statistic: np.ndarray | None


class _TrajectoryRows:
    """trajectory.csv's rows appended as they become final, to a file opened by ``atomic.replacing`` (it appears
    complete or not at all)."""

    def __init__(self, f):
        from .outputs import TRAJECTORY_COLUMNS

        self._f = f
        f.write((",".join(TRAJECTORY_COLUMNS) + "\n").encode("ascii"))

    def push(self, rows: _FinalRows) -> None:
        from .outputs import TRAJECTORY_FORMATS, append_csv_rows, trajectory_columns

        r = rows.r
        append_csv_rows(self._f, trajectory_columns(r.t_s, r.pos_n, r.vel_n, r.stance, r.q_nb), TRAJECTORY_FORMATS)

    def close(self) -> None:
        """Nothing: ``atomic.replacing`` closes and commits the file."""


class _ResultsRows:
    """results.h5's per-sample rows (``outputs.ResultsWriter``) appended as they become final, into a temporary
    copy beside the target (``outputs.start_results``: the recording's groups copied or linked) that ``commit``
    finishes (attributes, the strides) and renames over the target."""

    UNITS = {"t_s": "s", "pos_n_m": "m", "vel_n_mps": "m/s", "q_nb": "1 (wxyz)", "stance": "1 (bool)",
             "acc_bias_b_mps2": "m/s^2", "gyro_bias_b_radps": "rad/s", "pos_sigma_n_m": "m",
             "stance_statistic": "detector-specific (see attrs stance_method, stance_threshold)"}
    STEP_UNITS = {"t_s": "s", "x_m": "m", "y_m": "m", "z_m": "m", "stride_length_m": "m", "dz_m": "m",
                  "yaw_enu_rad": "rad", "heading_deg_cw_from_north": "deg", "floor": "1"}

    def __init__(self, tmp: Path, target: Path, group: str, run, n: int):
        from .outputs import ResultsWriter, start_results

        self.tmp, self.target, self.group = tmp, target, group
        start_results(tmp, target, run.path, run.is_hdf5, run.recording, run.into_recording)
        self.writer = ResultsWriter(tmp, group, n, self.UNITS)

    def push(self, rows: _FinalRows) -> None:
        r = rows.r
        self.writer.append({"t_s": r.t_s, "pos_n_m": r.pos_n, "vel_n_mps": r.vel_n, "q_nb": r.q_nb,
                            "stance": r.stance.astype(np.uint8), "acc_bias_b_mps2": r.acc_bias_b,
                            "gyro_bias_b_radps": r.gyro_bias_b, "pos_sigma_n_m": r.pos_sigma_n,
                            "stance_statistic": rows.statistic})

    def commit(self, summary: dict, steps: dict, settings: ProcessSettings, sample_start: int,
               calibration: dict) -> str:
        """The group's attributes and strides written, the file renamed over the target; its ``file:group``."""
        import json

        from bootnav.core.conventions import CONVENTIONS, __version__
        from bootnav.core.jsonio import to_jsonable
        from bootnav.logger.recording import attach_dimension_scales, write_group

        from .outputs import heading_columns

        tmp, group = self.tmp, self.group
        self.writer.close()
        attrs = {"software": f"bootnav {__version__}", "settings": settings.to_json(indent=None),
                 "summary": json.dumps(to_jsonable(summary)), "sample_index_start": sample_start,
                 "created_utc": _utc_now(), "stance_method": settings.detector.method,
                 "stance_threshold": json.dumps(summary["stance"]["threshold"]),
                 "calibration": json.dumps(to_jsonable(calibration)),
                 **{f"convention_{k}": v for k, v in CONVENTIONS.items()}}
        write_group(tmp, group, {}, attrs, replace=False)
        write_group(tmp, f"{group}/steps", {**steps, **heading_columns(steps["yaw_enu_rad"])},
                    {"description": "one row per stride, see postproc/strides.py"}, self.STEP_UNITS)
        attach_dimension_scales(tmp, group)
        attach_dimension_scales(tmp, f"{group}/steps", dim="stride")
        atomic.commit(tmp, self.target)
        return f"{self.target}:{group}"

    def close(self) -> None:
        self.writer.close()


class _ReferenceRows:
    """The path's rows (t, x, y, z, stance) for a reference's metrics: a reference is compared with the whole
    path, so they go to a temporary file, read back memory-mapped by ``compute_metrics`` after the pass."""

    def __init__(self):
        import tempfile

        self._f = tempfile.TemporaryFile(prefix="bootnav-path-")

    def push(self, rows: _FinalRows) -> None:
        r = rows.r
        np.column_stack((r.t_s, r.pos_n, r.stance)).astype(np.float64).tofile(self._f)

    def rows(self, n: int) -> np.ndarray:
        """The n rows pushed, (n, 5), memory-mapped."""
        self._f.flush()
        return np.memmap(self._f, np.float64, "r", shape=(n, 5))

    def close(self) -> None:
        self._f.close()


class _ChartRows:
    """The path's rows for the charts (``plots.ChartStream``, which also takes the samples: ``push_imu``)."""

    def __init__(self, charts):
        self.charts = charts

    def push(self, rows: _FinalRows) -> None:
        r = rows.r
        self.charts.push_nav(r.t_s, r.pos_n, r.vel_n, r.q_nb, r.stance)

    def close(self) -> None:
        """Nothing: the charts are finished after the strides (``BlockPasses.write_files``)."""


class _GammaLog:
    """The adaptive detector's per-sample log10 γ, for its representative threshold 10^median (``adaptive``):
    spilled to a temporary file (the median exact from it, ``_order_statistics``), with its range (the
    detector's ``threshold_log10_range``). Inactive for another detector."""

    def __init__(self, active: bool):
        import tempfile

        self._f = tempfile.TemporaryFile(prefix="bootnav-gamma-") if active else None
        self.n = 0
        self.range = [np.inf, -np.inf]

    def push(self, ch) -> None:
        if self._f is not None and ch.threshold_log10 is not None:
            np.asarray(ch.threshold_log10, np.float64).tofile(self._f)
            self.n += len(ch)
            if len(ch):
                self.range[:] = [min(self.range[0], float(np.min(ch.threshold_log10))),
                                 max(self.range[1], float(np.max(ch.threshold_log10)))]

    def threshold(self, fixed):
        """10^median of the γ pushed (np.median, exact from the spilled rows); ``fixed`` without any."""
        if self._f is not None and self.n:
            n = self.n
            return float(10.0 ** np.mean(_order_statistics(lambda: _spilled(self._f, n), ((n - 1) // 2, n // 2))))
        return fixed

    def close(self) -> None:
        if self._f is not None:
            self._f.close()


class _FinalSinks:
    """Where the final pass's rows go, each sink with ``push(rows)`` and ``close()``: files (trajectory.csv,
    results.h5, the charts) with an output folder, else the memory of ``process`` (``pipeline._Collected``); the
    reference's rows with a reference. ``close`` closes every one and removes results.h5's temporary copy
    when it was not committed.

    Parameters
    ----------
    passes : BlockPasses
        The run (its input, settings, output folder and window).
    """

    def __init__(self, passes: BlockPasses):
        run, out, opts = passes.input, passes.out, passes.settings.output
        self.collect = run.rows
        if self.collect is not None:
            self.collect.reset()  # the fallback's passes run the final pass again: the rows of the last one
        self.results = self.reference = self.charts = None
        self._tmp = None
        self._sinks: list = []
        self.gamma = _GammaLog(passes.settings.detector.method == "adaptive")
        try:
            if out is not None:
                out.mkdir(parents=True, exist_ok=True)
                target = run.path if run.into_recording else out / "results.h5"
                self._tmp = atomic.temporary_beside(target)
            if opts.plots and out is not None:
                from .plots import ChartStream

                self.charts = ChartStream(passes.t_first, passes.t_last, passes.n, passes.gravity,
                                          opts.plot_max_points)
            if run.reference is not None:
                self.reference = _ReferenceRows()
                self._sinks.append(self.reference)
            if opts.write_hdf5 and out is not None:
                self.results = _ResultsRows(self._tmp, target, f"/results/{opts.results_name}", run, passes.n)
                self._sinks.append(self.results)
        except BaseException:
            self.close()
            raise
        if self.collect is not None:
            self._sinks.append(self.collect)
        if self.charts is not None:
            self._sinks.append(_ChartRows(self.charts))
        self.wants_statistic = self.results is not None or self.collect is not None

    def open_trajectory(self, f) -> None:
        """trajectory.csv's rows go to ``f`` (opened by ``atomic.replacing``) from now on."""
        self._sinks.insert(0, _TrajectoryRows(f))

    def push(self, rows: _FinalRows) -> None:
        for sink in self._sinks:
            sink.push(rows)

    def close(self) -> None:
        for sink in (self.results, self.reference, self.gamma):
            if sink is not None:
                sink.close()
        if self._tmp is not None:
            self._tmp.unlink(missing_ok=True)


def _with_stance_of(chunks, other):
    """``chunks`` (StanceChunks) with the stance of ``other`` (another detector's StanceChunks of the same samples,
    cut elsewhere): the fallback keeps the configured detector's statistic and takes another mask."""
    queue, upto, other = _RowQueue(), 0, iter(other)
    for ch in chunks:
        end = ch.start + len(ch)
        while upto < end:
            c = next(other)
            queue.put(c.start, np.asarray(c.stance, bool))
            upto = c.start + len(c)
        if len(ch):
            ch.stance = queue.take(ch.start, end)
        yield ch


class _CandidateScore:
    """One candidate of the stance fallback (``selftune``'s docstring) scored in a pass: a forward run of
    the filter (no smoother, the specific force not rotated by τ) on its mask, the RMS of its ZUPT-onset
    innovations and its stride flags (``selftune.StrideQualityAccumulator`` on the forward path)."""

    def __init__(self, name: str, init, gravity: float, dt0: float, filter_settings):
        from . import selftune
        from .ins.filter import navigator

        self.name = name
        self.nav = navigator(init, gravity, dt0, replace(filter_settings, smoother="none"))
        self.onsets = _OnsetInnovations()
        self.quality = selftune.StrideQualityAccumulator()
        self.gyro = _RowQueue()  # the gyro of the rows the navigator holds back
        self.phases = _Runs()
        self.n_stance = 0
        self.finite = True

    def _rows(self, r) -> None:
        if len(r):
            self.onsets.push(r)
            self.quality.push(r.t_s, r.pos_n, r.stance, self.gyro.take(r.start, r.start + len(r)), r.gyro_bias_b)
            self.finite = self.finite and bool(np.all(np.isfinite(r.pos_n)))

    def run(self, pairs, period_s: float, settings, n: int) -> dict:
        """Push every (StanceChunk, mask) of the record; the candidate's row (the summary's ``navigation.candidates``)."""
        for ch, mask in pairs:
            mask = np.asarray(mask, bool)
            self.phases.push(ch.start, mask)
            self.n_stance += int(np.count_nonzero(mask))
            self.gyro.put(ch.start, ch.gyro_b)
            self._rows(self.nav.push(ch.t_s, ch.acc_b, ch.gyro_b, mask, ch.saturated))
        self._rows(self.nav.finish())
        frac = self.n_stance / n
        if len(self.phases.starts) < 2:  # no stance-to-swing edge: not scored
            return {"name": self.name, "innovation_rms_mps": float("inf"), "bad_fraction": 1.0, "J": float("inf"),
                    "stance_fraction": frac}
        e = float(np.sqrt(self.onsets.mean_square(n))) if self.finite else float("inf")
        q = self.quality.finish(period_s, settings)
        return {"name": self.name, "innovation_rms_mps": e, "bad_fraction": q.bad_fraction,
                "J": e + settings.v_pen_mps * q.bad_fraction, "stance_fraction": frac, "_q": q}


def _cycle_minimum(chunks, n: int, bias_det, gravity_det: float, period_s: float, settings) -> np.ndarray | None:
    """``selftune.cycle_minimum_candidate`` of a record pushed as the configured detector's StanceChunks: the
    samples (t, specific force, rates less the rest bias, saturation) and the configured mask go to temporary
    files read back memory-mapped; the candidate's arithmetic (the SHOE statistic, its minima and their
    prominences over the whole record) makes temporaries of the record's length: the fallback's exception to
    memory bounded by the block (about 60 B per sample while it runs)."""
    import tempfile

    from . import selftune

    if not np.isfinite(period_s):
        return None
    with tempfile.TemporaryFile(prefix="bootnav-cycle-") as f:
        mm = np.memmap(f, np.float64, "w+", shape=(n, 9))  # t, acc (3), gyro less the bias (3), bad, configured
        for ch in chunks:
            a, b = ch.start, ch.start + len(ch)
            mm[a:b, 0] = ch.t_s
            mm[a:b, 1:4] = ch.acc_b
            mm[a:b, 4:7] = ch.gyro_b - bias_det
            mm[a:b, 7] = np.asarray(ch.saturated) != 0
            mm[a:b, 8] = np.asarray(ch.stance, bool)
        mm.flush()
        t = np.ascontiguousarray(mm[:, 0])
        return selftune.cycle_minimum_candidate(t, mm[:, 1:4], mm[:, 4:7], gravity_det, period_s, settings.detector,
                                                settings.selftune, mm[:, 7] > 0.5, mm[:, 8] > 0.5)


def _nominal_period(rec, rows: int = 1 << 20, cap: int = 1 << 20) -> float:
    """``timebase.nominal_period`` of every step of a reader's rows (the median of the positive finite steps, s),
    exact, from passes over its times ``rows`` at a time (``_order_statistics``). ValueError, as
    ``sample_period``, without a positive step."""
    def steps():
        prev = None
        for i0 in range(0, rec.n, rows):
            t = rec.times(i0, min(rec.n, i0 + rows))
            dt = np.diff(t if prev is None else np.concatenate(([prev], t)))
            prev = t[-1]
            yield dt[np.isfinite(dt) & (dt > 0)]

    m = sum(len(dt) for dt in steps())
    if m == 0:
        raise ValueError("the time axis has no positive step")
    return float(np.mean(_order_statistics(steps, ((m - 1) // 2, m // 2), cap)))  # as np.median


def _spilled(f, n: int, rows: int = 1 << 20):
    """The n float64 values written to the temporary file ``f``, read back ``rows`` at a time (8 MB): a
    memory map of the whole file would keep every page read resident until it is closed (8 B per sample,
    138 MB at 24 h at 200 Hz)."""
    f.flush()
    for i in range(0, n, rows):
        f.seek(8 * i)
        yield np.fromfile(f, np.float64, count=min(rows, n - i))
    f.seek(0, 2)  # the end again, where the next values are written


def _percentile(pieces, q: float, cap: int = 1 << 20) -> float:
    """``np.percentile(x, q)`` (linear) of the values ``pieces()`` yields, exact (``_order_statistics``)."""
    m = sum(len(v) for v in pieces())
    pos = q / 100.0 * (m - 1)
    lo = int(np.floor(pos))
    a, b = _order_statistics(pieces, (lo, min(lo + 1, m - 1)), cap)
    t = pos - lo
    return float(a + (b - a) * t if t < 0.5 else b - (b - a) * (1 - t))  # numpy's lerp


def _order_statistics(pieces, ks: tuple[int, int], cap: int = 1 << 20) -> np.ndarray:
    """The values of rank ``ks`` (0-based, ascending; ks[0] <= ks[1]) among every value ``pieces()`` yields (a
    generator called once per pass, e.g. over the blocks of a record), exact with bounded memory: each pass
    counts the values in the interval [lo, hi) known to hold both on a 4096-bin histogram and narrows it to
    their bins, until at most ``cap`` values are left in it (then sorted) or it is one float wide."""
    lo, hi = np.inf, -np.inf
    for v in pieces():
        if len(v):
            lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
    hi = float(np.nextafter(hi, np.inf))
    below = 0  # values < lo
    while True:
        if float(np.nextafter(lo, np.inf)) >= hi:  # one float wide: every value in it is lo
            return np.array([lo, lo])
        edges = np.linspace(lo, hi, 4097)
        edges[-1] = hi
        hist = np.zeros(4096, np.int64)
        inside: list | None = []  # the values in [lo, hi), kept while they are at most ``cap``
        count = 0
        for v in pieces():
            v = v[(v >= lo) & (v < hi)]
            count += len(v)
            hist += np.bincount(np.clip(np.searchsorted(edges, v, side="right") - 1, 0, 4095), minlength=4096)
            if inside is not None:
                inside.append(v)
                if count > cap:  # more: the histogram narrows the interval (bounded memory)
                    inside = None
        if inside is not None:
            v = np.sort(np.concatenate(inside)) if inside else np.zeros(0)
            return v[[ks[0] - below, ks[1] - below]]
        cum = below + np.cumsum(hist)
        b0, b1 = (int(np.searchsorted(cum, k, side="right")) for k in ks)  # the bins holding the two
        below = int(cum[b0 - 1]) if b0 else below
        lo, hi = float(edges[b0]), float(edges[b1 + 1])


class _PhaseInterpolation:
    """``np.interp(t_mid, t_s, values)`` at each stance phase's mid time (``strides.footprints``' t_mid) of rows
    pushed in consecutive chunks: the mid time lies between the phase's first and last sample, so the phase's
    own rows give numpy's interpolation (bounded memory: the open phase's rows)."""

    def __init__(self):
        self._out: list[float] = []
        self._t: list[np.ndarray] = []
        self._v: list[np.ndarray] = []

    def push(self, t_s, values, stance) -> None:
        from bootnav.core.runs import runs

        if not len(t_s):
            return
        starts, stops = runs(np.asarray(stance, bool))
        if self._t and (starts.size == 0 or starts[0] > 0):
            self._close()
        for a, b in zip(starts.tolist(), stops.tolist()):
            self._t.append(np.asarray(t_s[a:b], float))
            self._v.append(np.asarray(values[a:b], float))
            if b < len(t_s):
                self._close()

    def _close(self) -> None:
        if self._t:
            t, v = np.concatenate(self._t), np.concatenate(self._v)
            self._out.append(float(np.interp(0.5 * (t[0] + t[-1]), t, v)))
            self._t, self._v = [], []

    def finish(self) -> np.ndarray:
        self._close()
        return np.array(self._out)


class _LowestValues:
    """The ``q`` quantile of log10 T over the usable samples, as ``adaptive.AdaptiveDetector`` takes its noise
    floor (``np.quantile``, linear between order statistics), from chunks: only the smallest ⌊q (n − 1)⌋ + 2
    values can be those order statistics, n the samples of the record, so only they are kept (8 q bytes per
    sample: 7 MB at 24 h at 200 Hz). Equal to the whole-array floor to the last bit of the interpolation."""

    def __init__(self, q: float, n: int):
        self.q = float(q)
        self.k = int(np.floor(self.q * max(n - 1, 0))) + 2
        self._low = np.zeros(0)
        self._n = 0

    def add_chunk(self, ch, rest_floor: float) -> None:
        bad = (ch.saturated > 0) | ~np.all(np.isfinite(ch.acc_b), axis=1) | ~np.all(np.isfinite(ch.gyro_b), axis=1)
        L = np.log10(np.maximum(np.asarray(ch.statistic)[~bad], rest_floor))
        self._n += len(L)
        low = np.concatenate((self._low, L))
        self._low = np.partition(low, self.k - 1)[: self.k] if len(low) > self.k else low

    def quantile(self) -> float | None:
        if self._n == 0:
            return None
        s = np.sort(self._low)
        pos = self.q * (self._n - 1)
        lo = int(np.floor(pos))
        hi = min(lo + 1, len(s) - 1)
        t = pos - lo
        return float(s[lo] + (s[hi] - s[lo]) * t if t < 0.5 else s[hi] - (s[hi] - s[lo]) * (1 - t))


class _LogHistogram:
    """Median of positive values added in chunks, from a histogram of log10 in 1e-3-decade bins (bounded memory;
    within 0.12 % of the exact median, as ``detectors.stream``'s noise floor)."""

    LO, STEP, N = -8.0, 1e-3, 12_000

    def __init__(self):
        self._hist = np.zeros(self.N, np.int64)

    def add(self, values: np.ndarray) -> None:
        if len(values):
            x = np.log10(np.maximum(values, 1e-300))
            self._hist += np.bincount(np.clip(np.floor((x - self.LO) / self.STEP).astype(np.int64), 0, self.N - 1),
                                      minlength=self.N)

    def median(self) -> float:
        cum = np.cumsum(self._hist)
        k = int(np.searchsorted(cum, 0.5 * cum[-1], side="left"))
        return float(10 ** (self.LO + (k + 0.5) * self.STEP))


class _Runs:
    """The runs of True in a mask pushed in consecutive chunks: ``starts``, the absolute index of the first
    sample of every run, and ``stops(n)``, the index after its last (``core.runs.runs``' stops; a run still
    open at the end of the n samples stops at n)."""

    def __init__(self):
        from bootnav.core.arrays import GrowingRows

        self._starts, self._stops = GrowingRows(1, np.int64), GrowingRows(1, np.int64)  # 16 B per run
        self._prev = False

    def push(self, start: int, mask: np.ndarray) -> None:
        if len(mask):
            mask = np.asarray(mask, bool)
            before = np.concatenate(([self._prev], mask[:-1]))
            self._starts.extend(start + np.flatnonzero(mask & ~before))
            self._stops.extend(start + np.flatnonzero(~mask & before))
            self._prev = bool(mask[-1])

    @property
    def starts(self) -> np.ndarray:
        """The first sample of every run so far (a view)."""
        return self._starts.rows[:, 0]

    def stops(self, n: int) -> np.ndarray:
        return np.concatenate((self._stops.rows[:, 0], [n] if self._prev else [])).astype(np.int64)


class _OnsetInnovations:
    """``selftune.onset_innovations`` of a forward filter's rows pushed in order (``NavRows``: ``zupt`` is the
    mask after the onset delay): |v|² one sample before each ZUPT onset (the first phase, at sample 0, has no
    swing before it), with the onset's sample index."""

    def __init__(self):
        self._k0: list[np.ndarray] = []
        self._e2: list[np.ndarray] = []
        self._prev_zupt = True  # a phase at sample 0 is not an onset
        self._prev_v = np.zeros(3)

    def push(self, r) -> None:
        if not len(r):
            return
        z = np.asarray(r.zupt, bool)
        rise = np.flatnonzero(z & ~np.concatenate(([self._prev_zupt], z[:-1])))
        v_before = np.vstack((self._prev_v[None, :], r.vel_n[:-1]))[rise]
        self._k0.append(r.start + rise)
        self._e2.append(np.sum(v_before**2, axis=1))
        self._prev_zupt, self._prev_v = bool(z[-1]), np.array(r.vel_n[-1], float)

    def mean_square(self, cut: int) -> float:
        """Mean |v|² over the onsets before sample ``cut``, (m/s)²; inf without one."""
        k0 = np.concatenate(self._k0) if self._k0 else np.zeros(0, np.int64)
        e2 = np.concatenate(self._e2) if self._e2 else np.zeros(0)
        e2 = e2[k0 < cut]
        return float(np.mean(e2)) if len(e2) else float("inf")


def _probe_cut(starts: np.ndarray, n: int, fp_probe: dict, max_level_strides: int | None) -> int:
    """The samples ``selftune.level_timing_offset`` probes: whole stance phases, the first 2K + 1, doubled while
    either probe has fewer than K level strides in them, up to the whole record (its docstring); n = all."""
    from . import selftune

    if max_level_strides is None:
        return n
    phases = 2 * max_level_strides + 1
    while phases < len(starts):
        n_level = min(selftune.footprint_level_dz(t[:phases], fp[:phases], max_level_strides=max_level_strides)[1]
                      for t, fp in fp_probe.values())
        if n_level >= max_level_strides:
            return int(starts[phases])
        phases *= 2
    return n


class _ForwardProbes:
    """The forward filter runs of pass 2 (the timing calibration's two probes at ±δ, keyed -1 and 1, or the one
    run at 0 that scores the path), pushed chunk by chunk side by side in two threads (the kernel releases the
    GIL), and no further than the samples ``selftune.level_timing_offset`` reads: once both probes have emitted
    the rows before ``starts[2K + 1]`` (doubled as ``_probe_cut`` doubles it) with K level strides each there,
    the rest of the record changes none of their figures (the first K level strides, the onsets before the
    cut), so they stop: a long recording costs the probes of its first part, as in ``process``."""

    def __init__(self, navs: dict, probe_s: float, max_level_strides: int | None):
        import os

        from .strides import FootprintAccumulator

        self.navs = navs
        self.probe_s = probe_s
        self.k = max_level_strides
        self.fps = {s: FootprintAccumulator() for s in navs}
        self.onsets = {s: _OnsetInnovations() for s in navs}
        self.done = {s: 0 for s in navs}  # samples emitted by each run
        self.cut: int | None = None  # found: the runs stopped
        self._phases = None if max_level_strides is None else 2 * max_level_strides + 1
        self._pool = None
        if len(navs) > 1 and (os.cpu_count() or 1) > 1:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(max_workers=2)

    PIECE = 1 << 13  # samples pushed between two looks for the cut (41 s at 200 Hz)

    def _push(self, s: int, ch, a: int, b: int):
        from . import selftune

        acc, gyro = ch.acc_b[a:b], ch.gyro_b[a:b]
        f_rot = selftune.rotate_specific_force(acc, gyro, s * self.probe_s) if s else acc
        return self.navs[s].push(ch.t_s[a:b], f_rot, gyro, ch.stance[a:b], ch.saturated[a:b])

    def _keep(self, s: int, r) -> None:
        self.fps[s].push(r.t_s, r.pos_n, r.stance)
        self.onsets[s].push(r)
        self.done[s] = r.start + len(r)

    def push(self, ch, starts: np.ndarray) -> None:
        """Push a stance chunk (``starts``: the stance phases' first samples so far, this chunk's included)."""
        step = self.PIECE if self._phases is not None else max(len(ch.t_s), 1)
        for a in range(0, len(ch.t_s), step):
            if self.cut is not None:
                return
            b = min(a + step, len(ch.t_s))
            signs = list(self.navs)
            rows = (self._pool.map(lambda s: self._push(s, ch, a, b), signs) if self._pool is not None
                    else [self._push(s, ch, a, b) for s in signs])
            for s, r in zip(signs, rows):
                self._keep(s, r)
            self._look(starts)

    def _look(self, starts: np.ndarray) -> None:
        """``_probe_cut`` on the rows so far: stop the runs once it is decided."""
        from . import selftune

        while self._phases is not None and self._phases < len(starts):
            c = int(starts[self._phases])
            if min(self.done.values()) < c:
                return
            n_level = min(selftune.footprint_level_dz(fp.t_mid[:self._phases], fp.fp[:self._phases],
                                                      max_level_strides=self.k)[1] for fp in self.fps.values())
            if n_level >= self.k:
                self.cut = c
                self.navs = {}
                self._close()
                return
            self._phases *= 2

    def finish(self, starts: np.ndarray, n: int) -> tuple[dict, int, dict]:
        """({sign: (mid times, footprints)}, the probes' cut, {sign: _OnsetInnovations}) after the last chunk."""
        self._close()
        for s, nav in self.navs.items():
            self._keep(s, nav.finish())
        fp = {s: acc.finish() for s, acc in self.fps.items()}
        cut = self.cut if self.cut is not None else _probe_cut(starts, n, fp, self.k)
        return fp, cut, self.onsets

    def _close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None


class _RowQueue:
    """Per-sample rows pushed in order by absolute index and taken back in order (bounded memory: what was
    put and not yet taken)."""

    def __init__(self):
        self._parts: list[tuple[int, np.ndarray]] = []

    def put(self, start: int, rows: np.ndarray) -> None:
        if len(rows):
            self._parts.append((start, rows))

    def take(self, i0: int, i1: int) -> np.ndarray:
        """Rows i0..i1-1 (put before); everything before i1 is dropped."""
        out = []
        while self._parts and i0 < i1:
            start, rows = self._parts[0]
            a, b = i0 - start, min(i1 - start, len(rows))
            out.append(rows[a:b])
            i0 = start + b
            if b == len(rows):
                self._parts.pop(0)
            else:
                self._parts[0] = (start + b, rows[b:])
        return np.concatenate(out) if len(out) != 1 else out[0]


def _utc_now() -> str:
    import datetime as _dt

    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")

