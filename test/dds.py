"""DDS domains for the tests that start ROS nodes: each test process draws from its own share of a range, so that two
nodes started at once by different processes never share a domain (a process runs one test at a time).

The range is split into ``TEST_DDS_SHARES`` shares (default: one per pytest-xdist worker): xdist worker ``gw<i>``
takes share i, a process outside xdist share ``TEST_DDS_SHARE`` (default the last). ``make test`` runs the
``ros``-marked tests in a process of their own beside the xdist workers of the others, with one share more than
there are workers and the last share its own, so the nodes of the ros-marked tests and the in-process nodes of the
unmarked ones never meet."""

from __future__ import annotations

import os
import random


def domain_id(low: int, high: int) -> int:
    """A ROS_DOMAIN_ID drawn at random from this process's share of [low, high] (module docstring)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    shares = int(os.environ.get("TEST_DDS_SHARES", str(workers)))
    index = int(worker[2:]) if worker.startswith("gw") else int(os.environ.get("TEST_DDS_SHARE", str(shares - 1)))
    if not 0 <= index < shares:
        raise ValueError(f"DDS share {index} (xdist worker {worker or 'none'}) is not among TEST_DDS_SHARES={shares}")
    share = (high - low + 1) // max(shares, 1)
    if share < 1:
        raise ValueError(f"domains {low}–{high} cannot be split into {shares} shares")
    start = low + index * share
    return random.randint(start, start + share - 1)
