"""Errors of the bag adapters: one clear message (what, where, what to do), exit code 2 in the CLI."""

from __future__ import annotations

from ..core.errors import InputError


class BagError(InputError):
    """A bag (file or directory) or a topic in it cannot be used as asked; the message says what to do."""
