"""DDS domains for the tests that start ROS nodes: each pytest-xdist worker draws from its own share of a range, so
that two nodes started at once by different workers never share a domain (a worker runs one test at a time).
``make test`` runs the ``ros``-marked tests in one process after the others; ``pytest -n 2`` on all of them, or the
in-process nodes of the unmarked tests, still rely on this."""

from __future__ import annotations

import os
import random


def domain_id(low: int, high: int) -> int:
    """A ROS_DOMAIN_ID drawn at random from this process's share of [low, high]: the whole range outside xdist, else
    the worker's slice of it (``PYTEST_XDIST_WORKER`` = "gw<i>" of ``PYTEST_XDIST_WORKER_COUNT``)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    count = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    index = int(worker[2:]) if worker.startswith("gw") else 0
    share = (high - low + 1) // max(count, 1)
    if share < 1:
        raise ValueError(f"domains {low}–{high} cannot be split among {count} workers")
    start = low + index * share
    return random.randint(start, start + share - 1)
