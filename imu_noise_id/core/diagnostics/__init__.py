"""Residual diagnostics of fitted noise models and the streaming monitor (docs/loop.md, docs/diagnostics.md)."""
