"""``imu-noise-id loop BAG``: ``analyze`` with the starting model given and the closed loop on the chosen axes
(:func:`~.analyze.run`), its table of steps printed; the same files as ``analyze``."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import add_rate_option
from .options import add_analysis_options, add_out, add_topic

#: The effects the loop adds, for its help (equal to the loop's STATE/EXOG/CLEANING_EFFECTS: ``test_cli_style``).
LOOP_EFFECTS = ("GM", "RW", "RR", "QN", "OSC", "LPF", "MA", "BI", "SIN", "TEMP", "STEP", "OUTLIERS")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``loop`` parser."""
    from .analyze import run

    p = subparsers.add_parser(
        "loop",
        help=f"closed loop: find the effects the noise model misses ({', '.join(LOOP_EFFECTS)})",
        description=(
            "analyze from a given starting model on chosen axes: fit it to each axis of a static bag, test its "
            "residuals (standardised innovations, Allan variance against the model's) for missing effects, add the "
            "most significant one (state-space component, deterministic regressor or outlier removal), refit, and "
            "keep it only if the BIC improves and its evidence is gone; repeat until the residuals pass or nothing "
            "improves. Prints the steps and writes what analyze writes: DIR/model.yaml (a 'loop:' list per axis "
            "with the errors before and after each step), DIR/report.html (with the loop's before/after Allan plots "
            "and residual ACF/PSD), imu.yaml and the exports. A sensor_msgs/Temperature topic in the bag enables "
            "the thermal-bias test."
        ),
    )
    p.add_argument("bag", type=Path, help="bag file or rosbag2 directory")
    add_topic(p)
    add_out(p, "loop")
    add_rate_option(p)
    add_analysis_options(p, "loop")
    p.set_defaults(run=run)
