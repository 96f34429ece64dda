"""Guided live calibration: ``bootnav calibrate --port P``.

The boot's frames are recorded by the logger's own serial recorder (``logger.serial_recorder.SerialRecorder``,
the path of ``bootnav record``: same decoder, same crash-safe file) in a thread, into ``--record FILE.h5``
(default ``calibration-<UTC>.h5`` here, never overwritten). A tap on the recorder's sample blocks keeps the
session in memory in SI units, and the main thread guides the person:

* still test of the last ``window_s`` (``static.still_windows``, the fit's own thresholds): "hold still …
  3 s" counts down while the boot is still, and a pose is done after ``--hold`` seconds still;
* then the next pose of the procedure (``PROCEDURE``: the faces, 45° tilts, rotations about every axis, a
  full turn on the table), "now turn the boot onto its left side";
* from the 9th pose on, after each pose the fit runs on what has been recorded (``fit.calibrate`` with
  ``require_determined=False``) and the parameters still undetermined or short of the goals are shown; once
  the procedure is done, the next instruction is the hint of the worst parameter (which rotation to add);
* it stops when every parameter reaches the goals, after ``--duration``, when the boot stops sending, or on
  Ctrl-C, then fits the whole recorded file and stores the calibration like ``bootnav calibrate FILE``.
"""

from __future__ import annotations

import math
import signal
import sys
import threading
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from bootnav.errors import BootnavError, InputError

from .settings import SensorCalSettings

#: The guided procedure: what to do to reach each next pose (boot words; x along the foot, z up the leg).
PROCEDURE = (
    "put the boot flat on its sole on the table",
    "roll it halfway onto its left side (45°)",
    "roll it onto its left side",
    "roll it on until it is upside down",
    "roll it onto its right side",
    "roll it back flat onto its sole",
    "tip it up onto its heel, toe pointing up",
    "lay it back flat",
    "tip it forward onto its toe, heel pointing up",
    "tip it halfway back (45°, toe down)",
    "lay it back flat",
    "turn it one full turn flat on the table, stopping where it started",
    "lay it on its left side",
    "on its side, turn it so the toe points up",
    "on its side, turn it halfway back (toe 45° up)",
    "on its side, turn it so the toe points down",
    "on its side, turn it back level",
    "roll it back flat onto its sole",
    "tip it halfway onto its right side (45°)",
    "roll it back flat onto its sole",
)
STILL_SILENCE_S = 5.0  # the boot stopped sending for this long: stop and fit what there is
UPDATE_S = 0.25  # guide refresh period


class _Tap:
    """Collects the recorder's sample blocks (counts) and gives the session so far in SI units."""

    def __init__(self):
        self.lock = threading.Lock()
        self.blocks: list[dict] = []
        self.scale = None  # (acc m/s² per count, gyro rad/s per count)
        self.device_id = None
        self.last_time = None

    def add(self, block: dict, header) -> None:
        from bootnav.logger import mpu6050
        from bootnav.logger.serial_recorder import DEFAULT_ACCEL_FS, DEFAULT_GYRO_FS

        a_fs = header.accel_fs if header is not None else DEFAULT_ACCEL_FS
        g_fs = header.gyro_fs if header is not None else DEFAULT_GYRO_FS
        with self.lock:
            if self.scale is None:
                self.scale = (mpu6050.accel_scale_mps2(a_fs), mpu6050.gyro_scale_radps(g_fs))
            if header is not None and self.device_id is None:
                self.device_id = f"0x{header.device_id:08X}"
            self.blocks.append({k: block[k] for k in ("t_s", "acc", "gyro", "temp")})
            self.last_time = time.monotonic()

    def arrays(self):
        from bootnav.logger import mpu6050

        with self.lock:
            if not self.blocks:
                return None
            if len(self.blocks) > 1:
                self.blocks = [{k: np.concatenate([b[k] for b in self.blocks]) for k in self.blocks[0]}]
            b = self.blocks[0]
            sa, sg = self.scale
        return (b["t_s"].astype(np.float64), b["acc"] * sa, b["gyro"] * sg,
                mpu6050.temp_counts_to_degc(b["temp"].astype(np.float64)))


def _recorder_class():
    from bootnav.logger.serial_recorder import SerialRecorder

    class TappedRecorder(SerialRecorder):
        """``SerialRecorder`` that also hands every decoded block to a ``_Tap`` (nothing else changes)."""

        tap: _Tap

        def _on_samples(self, samples, host_time):
            super()._on_samples(samples, host_time)
            self.tap.add(self._pending[-1], self._header)

    return TappedRecorder


def default_record_path(directory: Path | None = None) -> Path:
    """``calibration-<UTC>.h5`` in ``directory`` (default the current one), with -2, -3 … if it exists."""
    d = Path.cwd() if directory is None else Path(directory)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    path = d / f"calibration-{stamp}.h5"
    n = 2
    while path.exists():
        path = d / f"calibration-{stamp}-{n}.h5"
        n += 1
    return path


class Guide:
    """The instructions: which pose comes next, when to hold still, what is still undetermined."""

    def __init__(self, settings: SensorCalSettings, hold_s: float, out=None):
        self.s = settings
        self.hold_s = hold_s
        self.out = out if out is not None else sys.stdout
        self.step = 0  # index into PROCEDURE of the pose being asked for
        self.poses_done = 0
        self.state = "place"  # place (waiting for a hold) -> move (waiting for motion after a pose) -> place
        self.done_until = 0  # sample index: holds before it are counted
        self.last_line = ""
        self.done = False
        self.hint = None
        self.status = ""

    def say(self, text: str) -> None:
        if text != self.last_line:
            print(text, file=self.out, flush=True)
            self.last_line = text

    def instruction(self) -> str:
        if self.step < len(PROCEDURE):
            return PROCEDURE[self.step]
        return self.hint or PROCEDURE[1 + (self.step - len(PROCEDURE)) % (len(PROCEDURE) - 1)]

    def update(self, t_s, acc, gyro, temp) -> bool:
        """Advance on the data so far; True when at least one pose was completed (the caller refits then).

        Works on every sample since the last completed pose (not on the latest instant), so a replay faster
        than real time or a slow refresh never misses a hold: a run of still windows (``still_windows``)
        lasting ``hold_s`` of sensor time completes a pose; the next pose counts only after some motion.
        """
        from bootnav.core.runs import runs

        from .static import still_windows

        n = t_s.size
        if n < 10:
            return False
        dt = float(np.median(np.diff(t_s[-min(n, 400):])))
        n_win = max(3, int(round(self.s.window_s / dt)))
        lo = max(0, self.done_until - 2 * n_win)
        still = still_windows(t_s[lo:], acc[lo:], gyro[lo:], self.s)
        # the centred window of the last half window is not complete yet: treat it as unknown (not still)
        valid = max(0, still.size - n_win // 2)
        still[valid:] = False
        completed = False
        while True:
            i0 = self.done_until - lo
            if self.state == "move":  # the pose just completed must end before the next one counts
                moving = np.flatnonzero(~still[i0:valid])
                if moving.size == 0:
                    return completed
                self.done_until += int(moving[0])
                self.state = "place"
                continue
            starts, stops = runs(still[i0:])
            starts, stops = starts + i0, stops + i0
            dur = t_s[lo + np.maximum(stops - 1, 0)] - t_s[lo + starts]
            full = np.flatnonzero(dur >= self.hold_s)
            if full.size == 0:
                break
            a = int(starts[full[0]])
            self.done_until = lo + a + int(np.searchsorted(t_s[lo + a:], t_s[lo + a] + self.hold_s))
            self.poses_done += 1
            self.step += 1
            self.state = "move"
            completed = True
            self.say(f"pose {self.poses_done} done. now {self.instruction()}")
        if starts.size and stops[-1] >= valid:
            left = self.hold_s - (t_s[-1] - t_s[lo + starts[-1]])
            self.say(f"pose {self.poses_done + 1}: hold still … {max(1, math.ceil(left)):d} s")
        else:
            self.say(f"pose {self.poses_done + 1}: {self.instruction()}, then hold still")
        return completed

    def show_fit(self, res) -> None:
        """After a refit: what is undetermined or short of the goals; done when nothing is."""
        from .fit import format_sigma

        if res.undetermined:
            names = ", ".join(f"{n} ({format_sigma(n, sd)})" for n, sd, _, _ in res.undetermined[:4])
            more = f" and {len(res.undetermined) - 4} more" if len(res.undetermined) > 4 else ""
            self.say(f"  undetermined: {names}{more}")
            self.hint = res.undetermined[0][3]
        elif res.below_goal:
            names = ", ".join(f"{n} ({format_sigma(n, sd)})" for n, sd, _ in res.below_goal[:4])
            more = f" and {len(res.below_goal) - 4} more" if len(res.below_goal) > 4 else ""
            self.say(f"  short of the goals: {names}{more}")
            worst = res.below_goal[0][0]
            axis = worst[-1] if worst.startswith("gyroscope C_") else None
            from .fit import ROTATE_HINT

            self.hint = ROTATE_HINT.get(axis) if axis else None
        else:
            self.say("  every parameter is determined to the goals: done")
            self.done = True


def run_live(args, settings: SensorCalSettings) -> int:
    """The guided live mode (module docstring)."""
    from bootnav.logger.serial_recorder import RecorderSettings

    from .report import finish
    from .fit import MIN_POSES, Session, calibrate, load_session

    if not math.isfinite(args.hold) or not args.hold >= settings.min_pose_s + 2 * settings.edge_trim_s:
        raise InputError(f"--hold {args.hold}: hold each pose at least "
                         f"{settings.min_pose_s + 2 * settings.edge_trim_s:g} s (the fit needs "
                         f"{settings.min_pose_s:g} s of stillness after trimming the edges)")
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise InputError(f"--duration {args.duration}: must be a positive number of seconds")
    record = Path(args.record) if args.record else default_record_path()
    if record.exists():
        raise InputError(f"--record {record}: exists; recordings are never overwritten, choose another name")
    if not record.resolve().parent.is_dir():
        raise InputError(f"--record {record}: the directory {record.resolve().parent} does not exist")

    baud = {"baud": args.baud} if args.baud is not None else {}  # else RecorderSettings' default
    rec = _recorder_class()(RecorderSettings(port=args.port, out=str(record), **baud), status_stream=None)
    rec.tap = _Tap()
    failure: list[BaseException] = []

    def work():
        try:
            rec.run()
        except BaseException as exc:  # noqa: BLE001 - handed to the main thread
            failure.append(exc)

    thread = threading.Thread(target=work, name="calibrate-recorder", daemon=True)
    old_term = signal.signal(signal.SIGTERM, lambda *_: rec.stop("SIGTERM"))
    guide = Guide(settings, args.hold)
    print(f"bootnav calibrate: recording {args.port} into {record}; Ctrl-C stops and fits what there is",
          file=sys.stderr, flush=True)
    t_start = time.monotonic()
    stop_reason = ""
    thread.start()
    try:
        while thread.is_alive():
            time.sleep(UPDATE_S)
            if args.duration is not None and time.monotonic() - t_start > args.duration:
                stop_reason = f"--duration {args.duration:g} s reached"
                break
            last = rec.tap.last_time
            if last is not None and time.monotonic() - last > STILL_SILENCE_S:
                stop_reason = f"the boot sent nothing for {STILL_SILENCE_S:g} s"
                break
            data = rec.tap.arrays()
            if data is None:
                continue
            if guide.update(*data) and guide.poses_done >= MIN_POSES:
                t, a, g, temp = data
                ses = Session("live", t, a, g, temp, None, rec.tap.device_id)
                try:
                    res = calibrate([ses], settings, device_id=args.device_id, require_determined=False)
                except InputError as exc:  # not enough yet (e.g. no usable motion): keep guiding
                    guide.say(f"  not yet: {str(exc).split(': ', 1)[-1]}")
                    continue
                guide.show_fit(res)
                if guide.done:
                    stop_reason = "every parameter determined to the goals"
                    break
    except KeyboardInterrupt:
        stop_reason = "interrupted (Ctrl-C): fitting what was recorded"
    finally:
        rec.stop(stop_reason or "stopped")
        thread.join(timeout=30)
        signal.signal(signal.SIGTERM, old_term)
    if failure:
        raise failure[0]
    if rec.disk_full is not None:
        raise rec.disk_full
    if not record.exists():
        raise BootnavError(f"no data received from {args.port} ({rec.stats.stop_reason}); {record} not written")
    print(f"bootnav calibrate: {stop_reason or rec.stats.stop_reason}; session in {record}", file=sys.stderr)
    session = load_session(record)
    dev = args.device_id or session.device_id
    if dev is None and not args.out:
        raise InputError(f"{record}: the boot sent no device id; run `bootnav calibrate {record} --device-id ID` "
                         "or with --out FILE.json")
    res = calibrate([session], settings, device_id=args.device_id)
    finish(args, res)
    return 0
