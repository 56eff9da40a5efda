"""A small text progress bar on stderr for long operations (drawn only when stderr is a terminal); lines printed
meanwhile go through :meth:`TextProgress.echo`, which clears the bar first."""

from __future__ import annotations

import sys
import time
from typing import TextIO


def _seconds(s: float) -> str:
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.1f} min"


class TextProgress:
    """Callable ``progress(done, total)`` drawing ``label [#####.....]  45 % (9/20 units) 12 s, ~15 s left``.

    Draws at most every ``interval`` seconds; :meth:`close` ends the line. Does nothing when ``stream`` is not a
    TTY. The time left is extrapolated from the rate so far.
    """

    def __init__(self, label: str, stream: TextIO | None = None, width: int = 30, interval: float = 0.2,
                 unit: str = "") -> None:
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.interval = interval
        self.unit = f" {unit}" if unit else ""
        self.enabled = bool(getattr(self.stream, "isatty", lambda: False)())
        self._start = time.monotonic()
        self._last = 0.0
        self._drawn = False
        self._state = (0, 0)

    def _line(self) -> str:
        done, total = self._state
        frac = min(max(done / total, 0.0), 1.0) if total > 0 else 0.0
        filled = round(frac * self.width)
        elapsed = time.monotonic() - self._start
        if 0 < frac < 1:
            left = f", ~{_seconds(elapsed * (1 - frac) / frac)} left"
        else:
            left = f", time left known after the first of the {total}{self.unit}" if done == 0 and total > 1 else ""
        return (f"\r{self.label} [{'#' * filled}{'.' * (self.width - filled)}] {100 * frac:5.1f} % "
                f"({done}/{total}{self.unit}) {_seconds(elapsed)}{left}")

    def __call__(self, done: int, total: int) -> None:
        self._state = (done, total)
        if not self.enabled:
            return
        now = time.monotonic()
        if now - self._last < self.interval and 0 < done < total:
            return
        self._last = now
        self.stream.write(self._line() + "\033[K")
        self.stream.flush()
        self._drawn = True

    def echo(self, text: str, out: TextIO | None = None) -> None:
        """Print ``text`` (to stdout by default) without mixing it with the bar, which is redrawn after it."""
        if self._drawn:
            self.stream.write("\r\033[K")
            self.stream.flush()
        print(text, file=out or sys.stdout, flush=True)
        if self._drawn:
            self.stream.write(self._line() + "\033[K")
            self.stream.flush()

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
