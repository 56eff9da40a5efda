"""A value computed on first use (a diagnosis's detectors, its spectra, its peak ratio): what a refused candidate
never needs is never computed."""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T")


class Deferred(Generic[T]):
    """A value computed by ``compute()`` on first use and kept (copies of its holder share it); pickled as the value."""

    def __init__(self, compute: Callable[[], T]) -> None:
        self._compute: Callable[[], T] | None = compute
        self._value: T | None = None

    def __call__(self) -> T:
        if self._compute is not None:
            self._value, self._compute = self._compute(), None
        return self._value  # type: ignore[return-value]

    def __getstate__(self) -> dict[str, object]:
        return {"_compute": None, "_value": self()}
