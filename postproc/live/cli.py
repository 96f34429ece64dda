"""``bootnav live``: record one or several boots and watch their paths grow in the browser.

``--port P [--port Q ...] --out DIR``: one ``bootnav record`` child per port writes ``DIR/<label>.h5``
(lossless, exactly as ``record``); the view tails those files. ``--replay FILE.h5 ...`` shows finished
recordings through the same page (every boot of a multi-boot recording, on its shared clock). ``--demo``
simulates two walks, serves them on emulated boots (``bootnav emulate``) and records and shows them live. The
page is at the printed URL (loopback only unless ``--host`` and a token are given). Ctrl-C stops the recorders
cleanly and writes ``DIR/live.json`` (the live strides of every boot and the settings used).
"""

from __future__ import annotations

import argparse
import math
import sys


def add_arguments(parser: argparse.ArgumentParser) -> None:
    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--port", action="append", metavar="PORT",
                     help="serial port of one boot (repeat for several boots): /dev/ttyUSB0, a pty of "
                          "`bootnav emulate`")
    src.add_argument("--replay", nargs="+", metavar="FILE.h5",
                     help="show finished recordings instead (every boot of a multi-boot recording)")
    src.add_argument("--demo", action="store_true",
                     help="simulate two walks (three floors, a loop), stream them from emulated boots and show them")
    parser.add_argument("--label", action="append", metavar="NAME",
                        help="name of each boot in the legend and of its recording, in --port/--replay order "
                             "(default: the port's or file's name)")
    parser.add_argument("--out", metavar="DIR", help="directory of the recordings DIR/<label>.h5 and DIR/live.json "
                                                     "(required with --port; --demo: a new temporary directory)")
    parser.add_argument("--force", action="store_true", help="overwrite existing recordings and live.json in --out")
    parser.add_argument("--baud", type=int, default=None, help="serial baud rate (default 500000)")
    parser.add_argument("--speed", type=float, default=1.0, metavar="X",
                        help="--replay: recording seconds per second (default 1)")
    parser.add_argument("--no-motion-s", type=float, default=30.0, metavar="S",
                        help="alarm after S s without motion (default 30: the PASS-device rule, NFPA 1982)")
    parser.add_argument("--settings", metavar="FILE.json",
                        help="ProcessSettings as JSON (detector, filter, floors), as for `bootnav process`")
    parser.add_argument("--detector", metavar="NAME",
                        help="stance detector (default: the settings'; streamable: adaptive, shoe, ared, mv, mag, "
                             "shoe-literal with a threshold). The final stride is drawn a median 1.8-2.0 s after its "
                             "stance phase began with adaptive, 0.63 s with shoe; with either, a provisional (hollow) "
                             "marker a median 0.27-0.31 s after it (benchmarks/bench_live.py, docs/live.md)")
    from bootnav.postproc.cli_process import add_calibration_arguments

    add_calibration_arguments(parser)
    parser.add_argument("--host", default="127.0.0.1",
                        help="address to serve on (default 127.0.0.1; any other needs --token)")
    parser.add_argument("--http-port", type=int, default=8017, metavar="N",
                        help="TCP port number of the page (default 8017; 0 picks a free one)")
    parser.add_argument("--token", metavar="T",
                        help="access token every request must carry; 'auto' generates one (printed in the URL)")


def _check(args) -> None:
    from bootnav.errors import BootnavError

    from bootnav.core.limits import check_range

    for flag, value in (("--speed", args.speed), ("--no-motion-s", args.no_motion_s)):
        if not (math.isfinite(value) and value > 0):
            raise BootnavError(f"{flag} {value}: must be a positive number")
    check_range("--speed", args.speed, 0.0, 1000.0, "x real time", lo_open=True)
    check_range("--no-motion-s", args.no_motion_s, 0.0, 3600.0, "s", lo_open=True,
                why="the PASS-device alarm time is 30 s")
    if not 0 <= args.http_port <= 65535:
        raise BootnavError(f"--http-port {args.http_port}: must be in 0..65535")
    if args.port and not args.out:
        raise BootnavError("--port needs --out DIR: the recordings are written there")
    if args.label and args.demo:
        raise BootnavError("--label: the demo names its boots itself")
    if args.replay and args.out:
        raise BootnavError("--replay writes nothing; drop --out")
    from .server import is_loopback

    if not is_loopback(args.host) and not args.token:
        raise BootnavError(f"--host {args.host}: not the loopback address; the view would be open to the network, "
                           "so give --token T (or --token auto) so that every request must carry it")


def run(args) -> int:
    import signal
    import tempfile
    from pathlib import Path

    import threading

    from bootnav.core.progress import Progress
    from bootnav.errors import BootnavError
    from bootnav.postproc.detectors.stream import StreamStance
    from bootnav.postproc.settings import ProcessSettings

    from .boot import BootView, LiveSettings, warm_up
    from .server import Hub, LiveServer, new_token
    from .session import (Feed, Session, hello, labels_for, out_paths, start_recorder, stop_recorder)
    from .sources import GrowingRecording, ReplayRecording

    _check(args)
    settings = ProcessSettings.from_file(args.settings) if args.settings else ProcessSettings()
    if args.detector:
        try:
            settings.detector = settings.detector.with_method(args.detector)
        except ValueError as exc:
            raise BootnavError(f"--detector {args.detector}: {exc}") from None
    from bootnav.postproc.cli_process import apply_calibration_arguments

    apply_calibration_arguments(args, settings.calibration)
    settings.validate()
    StreamStance(settings.detector, 200.0)  # a detector that needs the whole record fails here, not mid-walk
    live = LiveSettings(no_motion_s=args.no_motion_s)
    progress = Progress(quiet=args.quiet)
    token = new_token() if args.token == "auto" else args.token
    helpers = []  # demo emulators
    out_dir = Path(args.out) if args.out else None
    offsets = None
    if args.demo:
        out_dir = out_dir or Path(tempfile.mkdtemp(prefix="bootnav-live-demo-"))
        ports, labels, offsets = _start_demo(out_dir, helpers, progress)
    elif args.port:
        ports, labels = args.port, labels_for(args.port, args.label)
    feeds = []
    try:
        if args.replay:
            boots = _replay_boots(args.replay)
            labels = labels_for([name for _, _, name in boots], args.label)
            for i, ((path, boot, _), label) in enumerate(zip(boots, labels)):
                source = ReplayRecording(path, args.speed, boot=boot)
                feeds.append(Feed(str(i), label, source, BootView(label, settings, live)))
        else:
            paths = out_paths(out_dir, labels, args.force)
            _check_summary(out_dir, args.force)
            for i, (port, label, path) in enumerate(zip(ports, labels, paths)):
                log = out_dir / f"{label}.record.log"
                rec = start_recorder(port, path, log, live.flush_interval_s, args.baud, label, args.force)
                feeds.append(Feed(str(i), label, GrowingRecording(path), BootView(label, settings, live), rec, log))
        hub = Hub(hello(feeds, "replay" if args.replay else "live", args.speed, live.no_motion_s,
                        settings.floor_height_m, offsets))
        server = LiveServer(hub, args.host, args.http_port, token).start()
        threading.Thread(target=_quietly, args=(warm_up, settings), name="bootnav-live-warm-up", daemon=True).start()
        print(f"bootnav live: open {server.url}", flush=True)
        if out_dir is not None and not args.quiet:
            print(f"bootnav live: recordings in {out_dir}", file=sys.stderr, flush=True)
        session = Session(feeds, hub, live.poll_s)
        # Ctrl-C and SIGTERM end the session cleanly, even when started with SIGINT ignored (a background job)
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: session.stop_event.set())
        try:
            session.run()
            if session.error:
                raise BootnavError(session.error)
            if not session.stop_event.is_set():
                progress.update("all boots ended; the page stays open until Ctrl-C", force=True)
            while not session.stop_event.wait(0.5):
                pass
        finally:
            session.stop_recorders()
            server.stop()
            if out_dir is not None and not args.replay and any(f.view.result()["rows"] for f in feeds):
                path = _write_summary(out_dir, feeds, settings, live)
                progress.done(f"live strides written to {path}")
    finally:
        for feed in feeds:
            if feed.recorder is not None:
                stop_recorder(feed.recorder)
        for proc in helpers:
            stop_recorder(proc)
    return 0


def _replay_boots(paths: list[str]) -> list[tuple[str, str | None, str]]:
    """(path, boot, default label) per boot to replay: one per single-boot file, one per boot of a multi-boot
    recording (labelled by the boot, or ``<file>-<boot>`` when several files are replayed)."""
    from pathlib import Path

    from bootnav.logger.recording import boot_labels

    out = []
    for path in paths:
        labels = boot_labels(path) if Path(path).is_file() else []  # a missing file: ReplayRecording says so
        if not labels:
            out.append((path, None, path))
        for b in labels:
            out.append((path, b, b if len(paths) == 1 else f"{Path(path).stem}-{b}"))
    return out


def _quietly(func, *args) -> None:
    """Run an optional speed-up (the kernels' warm-up); a failure there shows up again, with its message, when
    the first boot is navigated."""
    try:
        func(*args)
    except Exception:  # noqa: BLE001 - see docstring
        pass


def _check_summary(out_dir, force: bool) -> None:
    from bootnav.errors import BootnavError

    from bootnav.core.paths import output_folder

    output_folder(out_dir, ["live.json"], force=force)  # the one output rule (bootnav.core.paths)


def _write_summary(out_dir, feeds, settings, live):
    """``live.json``: per boot the final stride rows and figures, and the settings (temp file + rename)."""
    import json
    from bootnav.core import atomic
    from bootnav.core.jsonio import to_jsonable

    data = {"settings": settings.to_dict(), "live_settings": to_jsonable(live),
            "boots": {f.label: {**f.view.result(), "calibration": (f.view.calibration.provenance if f.view.calibration
                                                                     else {"status": "none", "reason": "no samples"})}
                      for f in feeds}}
    text = json.dumps(to_jsonable(data, max_array_size=None), indent=1, allow_nan=False) + "\n"
    return atomic.write_text(out_dir / "live.json", text)


#: gap between the demo walks as drawn, m (two walkers' paths side by side, not on top of each other)
DEMO_GAP_M = 3.0


def demo_offsets(radii_m: list[float]) -> list[tuple[float, float]]:
    """East shifts that draw walks side by side, whatever their heading: walk k's start is placed so that the
    discs around each start holding its whole walk (``radii_m``: the largest horizontal distance from its own
    start, m) are ``DEMO_GAP_M`` apart."""
    out, x = [], 0.0
    for k, r in enumerate(radii_m):
        if k:
            x += radii_m[k - 1] + DEMO_GAP_M + r
        out.append((x, 0.0))
    return out


def _start_demo(out_dir, helpers: list, progress):
    """Simulate two walks into ``out_dir`` and serve each on an emulated boot; return (ports, labels, the
    drawing offsets that put the walks side by side)."""
    import subprocess

    import numpy as np

    from bootnav.logger.recording import load
    from bootnav.simulator import simulate, write_h5

    from bootnav.errors import BootnavError

    out_dir.mkdir(parents=True, exist_ok=True)
    ports, labels, radii = [], [], []
    for scenario, seed in (("three-floors", 0), ("rectangle", 1)):
        progress.update(f"demo: simulating the {scenario} walk", force=True)
        sim = out_dir / f"sim-{scenario}.h5"
        if sim.exists():
            raise BootnavError(f"{sim} exists; give --demo a new --out directory")
        walk = simulate(scenario, seed=seed, profile="mpu6050-16g-2000dps", rate_hz=200.0)
        write_h5(walk, sim)
        pos = load(sim).truth["pos_n_m"]
        radii.append(float(np.hypot(*(pos[:, :2] - pos[0, :2]).T).max()))
        link = out_dir / f"boot-{scenario}"
        helpers.append(subprocess.Popen(
            [sys.executable, "-m", "bootnav.cli", "emulate", "--out-link", str(link), "--source", str(sim), "--quiet"],
            stdin=subprocess.DEVNULL))
        ports.append(str(link))
        labels.append(scenario)
    return ports, labels, demo_offsets(radii)
