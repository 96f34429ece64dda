"""The progress display of every long command (``process``, ``eval``, ``emulate``, ``simulate``, ``live``):
one rewritten line on a terminal, a few plain lines in a log. In ``bootnav.core`` so that a subcommand needs
no import of the CLI dispatcher for it."""

from __future__ import annotations

import sys
import time


class Progress:
    """Progress lines that suit the terminal: a rewritten carriage-return line on a tty, plain lines in a log.

    On a tty the line is refreshed at most every ``tty_interval_s``; otherwise one plain line is
    written at most every ``log_interval_s``, so a redirected log holds a few readable lines and no
    carriage returns. ``quiet`` silences it.

    Parameters
    ----------
    stream : text stream, default ``sys.stderr``
    quiet : bool
    tty_interval_s, log_interval_s : float
    """

    def __init__(self, stream=None, *, quiet: bool = False, tty_interval_s: float = 0.5,
                 log_interval_s: float = 5.0):
        self.stream = stream if stream is not None else sys.stderr
        self.quiet = quiet
        try:
            self.tty = bool(self.stream.isatty())
        except (AttributeError, ValueError):
            self.tty = False
        self.interval_s = tty_interval_s if self.tty else log_interval_s
        self._last = -float("inf")
        self._width = 0

    def update(self, text: str, *, force: bool = False) -> None:
        """Show ``text`` if the interval has passed (or ``force``)."""
        if self.quiet:
            return
        now = time.monotonic()
        if not force and now - self._last < self.interval_s:
            return
        self._last = now
        if self.tty:
            pad = max(self._width - len(text), 0)
            self._width = len(text)
            print("\r" + text + " " * pad, end="", file=self.stream, flush=True)
        else:
            print(text, file=self.stream, flush=True)

    def done(self, text: str | None = None) -> None:
        """End the progress display, optionally with a final line."""
        if self.quiet:
            return
        if self.tty and self._width:
            print("\r" + " " * self._width + "\r", end="", file=self.stream, flush=True)
            self._width = 0
        if text:
            print(text, file=self.stream, flush=True)
