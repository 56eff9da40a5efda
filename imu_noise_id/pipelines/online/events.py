"""What the online identification reports besides its estimates: events for the node's log and per-period counts."""

from __future__ import annotations

from collections import deque


class EventLog:
    """Events ``(key, message)`` for the node's rate-limited log, and per-key counts of the diagnostics period."""

    def __init__(self) -> None:
        self._events: deque[tuple[str, str]] = deque(maxlen=100)
        self.window_counts: dict[str, int] = {}

    def event(self, key: str, text: str) -> None:
        """Report ``text`` (logged at most once per ``log_throttle`` per ``key``)."""
        self._events.append((key, text))

    def count(self, key: str) -> None:
        """Count one occurrence of ``key`` in the current period."""
        self.window_counts[key] = self.window_counts.get(key, 0) + 1

    def pop(self) -> list[tuple[str, str]]:
        """The events since the last call."""
        events = list(self._events)
        self._events.clear()
        return events

    def new_period(self) -> None:
        """Start a new diagnostics period."""
        self.window_counts = {}
