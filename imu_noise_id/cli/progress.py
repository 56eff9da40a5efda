"""A simple text progress bar on stderr for long operations (disabled when stderr is not a terminal)."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class TextProgress:
    """Callable ``progress(done, total)`` drawing ``label [#####.....]  45 % (done/total)`` on one line.

    Draws at most every ``interval`` seconds; :meth:`close` ends the line. Does nothing when ``stream`` is not
    a TTY (pipes, CI logs), so logs stay clean.
    """

    def __init__(self, label: str, stream: TextIO | None = None, width: int = 30, interval: float = 0.2) -> None:
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.interval = interval
        self.enabled = bool(getattr(self.stream, "isatty", lambda: False)())
        self._last = 0.0
        self._drawn = False

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if now - self._last < self.interval and done < total:
            return
        self._last = now
        frac = min(max(done / total, 0.0), 1.0) if total > 0 else 0.0
        filled = round(frac * self.width)
        bar = "#" * filled + "." * (self.width - filled)
        self.stream.write(f"\r{self.label} [{bar}] {100 * frac:5.1f} % ({done}/{total})")
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        """Finish the line if anything was drawn."""
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False

    def __enter__(self) -> TextProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
