"""One live session: the recorder children, the sources they fill, the per-boot views, the web server.

``bootnav live --port P ...`` starts one ``bootnav record`` child process per port (unchanged recorder, a
shorter flush interval so the file grows in small steps); this process only reads the growing files
(``sources.GrowingRecording``), so the view can never cost a recorder a frame. ``--replay FILE ...`` feeds
the same views from finished recordings (``sources.ReplayRecording``). One feeding thread polls every
source, pushes the new samples into its ``boot.BootView`` and publishes the new stride rows and the status
to the ``server.Hub``.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from bootnav.errors import BootnavError

from .boot import BootView
from .server import Hub

#: boot colours of the legend and the markers (distinct from the floor colours, which colour the path)
BOOT_COLORS = ("#d50000", "#2962ff", "#00c853", "#ff6d00", "#aa00ff", "#00b8d4", "#c51162", "#827717")


@dataclass
class Feed:
    """One boot: its id, label, source and view (and its recorder child when live)."""

    boot_id: str
    label: str
    source: object  # sources.GrowingRecording or sources.ReplayRecording
    view: BootView
    recorder: subprocess.Popen | None = None
    recorder_log: Path | None = None
    ended: bool = False


def start_recorder(port: str, out: Path, log: Path, flush_interval_s: float, baud: int | None, label: str,
                   force: bool) -> subprocess.Popen:
    """``bootnav record`` as a child process (its status lines go to ``log``); ``baud`` None: the recorder's
    default."""
    cmd = [sys.executable, "-m", "bootnav.cli", "record", "--port", port, "--out", str(out),
           *(["--baud", str(baud)] if baud is not None else []),
           "--flush-interval", str(flush_interval_s), "--subject", label, "--quiet"]
    if force:
        cmd.append("--force")
    with open(log, "w") as fh:
        return subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)


def stop_recorder(proc: subprocess.Popen, timeout_s: float = 10.0) -> int:
    """Stop a recorder as Ctrl-C does (it writes its pending block and closes the file); kill only if stuck."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


def _last_line(path: Path | None) -> str:
    try:
        lines = [ln for ln in path.read_text().splitlines() if ln.strip()] if path else []
    except OSError:
        return ""
    return lines[-1] if lines else ""


class Session:
    """Feeds every boot view from its source and publishes the results to the hub.

    Parameters
    ----------
    feeds : list of Feed
    hub : Hub
    poll_s : float, s
        Time between two polls of the sources: 0.1 s keeps the page within a flush interval of the recorder.
    """

    def __init__(self, feeds: list[Feed], hub: Hub, poll_s: float = 0.1):
        self.feeds = feeds
        self.hub = hub
        self.poll_s = poll_s
        self.stop_event = threading.Event()
        self.error: str | None = None

    def step(self) -> bool:
        """Poll every source once; return True while any boot has more to come."""
        now = time.monotonic()
        status = {}
        for feed in self.feeds:
            if not feed.ended:
                chunk = feed.source.poll()
                if chunk is not None:
                    self.hub.add_rows(feed.boot_id, feed.view.push(chunk, now))
                    self.hub.set_provisional(feed.boot_id, feed.view.provisional)
                if feed.recorder is not None and feed.recorder.poll() is not None:
                    self._recorder_ended(feed)
                elif feed.recorder is None and feed.source.finished:
                    self.hub.add_rows(feed.boot_id, feed.view.finish())
                    self.hub.set_provisional(feed.boot_id, feed.view.provisional)
                    feed.ended = True
            status[feed.boot_id] = feed.view.status(now, feed.ended)
            status[feed.boot_id]["link"]["nominal_hz"] = feed.source.meta.get("rate_nominal_hz")
        self.hub.set_status(status)
        return not all(f.ended for f in self.feeds)

    def _recorder_ended(self, feed: Feed) -> None:
        """The recorder child exited: read what it flushed last, finish the view, report a failure."""
        chunk = feed.source.poll()
        if chunk is not None:
            self.hub.add_rows(feed.boot_id, feed.view.push(chunk, time.monotonic()))
        self.hub.add_rows(feed.boot_id, feed.view.finish())
        self.hub.set_provisional(feed.boot_id, feed.view.provisional)
        feed.source.close()
        feed.ended = True
        code = feed.recorder.returncode
        if code not in (0, 130, -signal.SIGINT) and not self.stop_event.is_set():
            why = _last_line(feed.recorder_log) or f"exit status {code}"
            feed.view.note = f"recorder stopped: {why}"
            if chunk is None:  # it never wrote a file: nothing to show for this boot
                self.error = f"recorder of {feed.label} failed: {why} (log: {feed.recorder_log})"

    def run(self) -> None:
        """Poll until ``stop_event`` is set or every source has ended."""
        while not self.stop_event.is_set():
            t0 = time.monotonic()
            if not self.step():
                break
            self.stop_event.wait(max(0.0, self.poll_s - (time.monotonic() - t0)))

    def stop_recorders(self) -> None:
        """Stop every recorder child cleanly, then read the last rows they flushed."""
        self.stop_event.set()
        for feed in self.feeds:
            if feed.recorder is not None:
                stop_recorder(feed.recorder)
        for feed in self.feeds:
            if feed.recorder is not None and not feed.ended:
                self._recorder_ended(feed)
        self.hub.set_status({f.boot_id: f.view.status(time.monotonic(), True) for f in self.feeds})


def hello(feeds: list[Feed], mode: str, speed: float, no_motion_s: float, floor_height_m: float,
          offsets_m: list | None = None) -> dict:
    """The first message of every page stream; ``offsets_m``: per boot an (east, north) shift of its drawing,
    m (the demo's walks, which both start at their own origin, are drawn side by side)."""
    from bootnav.postproc.plots import FLOOR_COLORS

    offsets_m = offsets_m or [(0.0, 0.0)] * len(feeds)
    return {"mode": mode, "speed": speed, "no_motion_s": no_motion_s, "floor_height_m": floor_height_m,
            "floor_colors": list(FLOOR_COLORS),
            "boots": [{"id": f.boot_id, "label": f.label, "color": BOOT_COLORS[i % len(BOOT_COLORS)],
                       "offset_m": [float(v) for v in offsets_m[i]]} for i, f in enumerate(feeds)]}


def labels_for(names: list[str], given: list[str] | None) -> list[str]:
    """One label per port or file: ``--label`` values in order, else the port's or file's name."""
    if given and len(given) != len(names):
        raise BootnavError(f"--label given {len(given)} times for {len(names)} boots; give one per --port/file")
    labels = list(given) if given else [Path(n).stem or n for n in names]
    bad = [lb for lb in labels if not lb or any(c in lb for c in "/\\\0") or lb.startswith(".")]
    if bad:
        raise BootnavError(f"--label {bad[0]!r}: not usable as a file name; use letters, digits, - and _")
    if len(set(labels)) != len(labels):
        raise BootnavError(f"labels {labels} are not distinct; give --label NAME once per --port")
    return labels


def out_paths(out_dir: Path, labels: list[str], force: bool) -> list[Path]:
    """``OUT/<label>.h5`` per boot; refuses to overwrite an existing recording without ``--force``."""
    from bootnav.core.paths import output_folder

    # the one output rule (bootnav.core.paths): never an existing file without --force, never a non-HDF5 file
    paths = output_folder(out_dir, [f"{lb}.h5" for lb in labels], force=force)
    out_dir.mkdir(parents=True, exist_ok=True)
    return paths
