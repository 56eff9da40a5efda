"""Rerun the benchmarks whose numbers README.md and docs/ quote; each output goes to docs/results/SCRIPT.txt.

Usage (``make bench`` runs the default set)::

    .venv/bin/python bench/run_all.py            # the issues' speed/memory goals (about 30 min; ../baseline)
    .venv/bin/python bench/run_all.py --long     # also the Monte-Carlo paper reproductions (hours)
    .venv/bin/python bench/run_all.py --studies  # also the studies of bench/studies/ that docs/ quotes (hours)
    .venv/bin/python bench/run_all.py --list     # what would run
    .venv/bin/python bench/run_all.py --only bench_allan.py bench_bags.py bench_analyze_memory.py   # issue 2's three

Benchmarks are not tests: they print numbers, they do not assert them. Each script can also be run alone
(its docstring gives the command). Scripts that need ``../shared/data`` say so and stop when it is absent.

An output file holds one section per run, each headed by its command line (``# python bench/SCRIPT ARGS``, a
side-by-side run's checkout written ``<baseline>``). A rerun replaces the sections of the runs it made and keeps the
others as they are, so that one file can hold a benchmark's quick and long runs, and several scripts' runs on one
question.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

BENCH = Path(__file__).resolve().parent
RESULTS = BENCH.parent / "docs" / "results"

#: Stands for ``--baseline``'s checkout in a job's arguments: the speed claims are measured side by side with it.
BASELINE = "<baseline>"
#: (script and arguments, output file in docs/results): the issues' "bench/ prints …" goals. One output file per
#: script, named after it; a script run several ways writes its runs as sections of that file.
GOALS: list[tuple[list[str], str]] = [
    (["bench_allan.py"], "bench_allan.txt"),
    (["bench_bags.py"], "bench_bags.txt"),
    (["bench_analyze_memory.py"], "bench_analyze_memory.txt"),
    (["bench_smoother_memory.py", "--baseline", BASELINE], "bench_analyze_memory.txt"),
    (["bench_em.py"], "bench_em.txt"),
    (["bench_em.py", "--quick"], "bench_em.txt"),
    (["bench_bank.py", "--skip-reproduction"], "bench_bank.txt"),
    (["bench_cmkf.py"], "bench_cmkf.txt"),
    (["bench_node.py", "--executor", "single_threaded"], "bench_node.txt"),
    (["bench_node.py", "--duration", "150", "--watch"], "bench_node.txt"),
    (["bench_analyze_time.py", "--baseline", BASELINE], "bench_analyze_time.txt"),
    (["bench_analyze_time.py", "--duration", "10800"], "bench_analyze_time.txt"),
    (["bench_analyze_time.py", "--rates", "100", "--duration", "660", "--repeats", "3", "--numbers", "--baseline",
      BASELINE], "bench_analyze_time.txt"),
    (["bench_analyze_time.py", "--rates", "200", "--duration", "86400", "--repeats", "2", "--baseline", BASELINE],
     "bench_analyze_time.txt"),
    (["bench_fit_time.py", "--samples", "360000", "--baseline", BASELINE], "bench_fit_time.txt"),
    (["bench_fit_time.py", "--samples", "10000000"], "bench_fit_time.txt"),
    (["bench_screen.py", "--seeds", "1", "2"], "bench_screen.txt"),
    (["bench_batch.py"], "bench_batch.txt"),
    (["bench_figures.py"], "bench_figures.txt"),
]

#: The random-walk bench's cells run by ``--long`` (its oscillation cell costs minutes per record: run alone).
RANDOM_WALK_CELLS = ["WN+GM20+RW", "WN+RW", "WN+GM100+RW", "WN+BI+RW"]
#: Long Monte-Carlo reproductions and measured-data benchmarks (``--long``).
LONG: list[tuple[list[str], str]] = [
    (["bench_bank.py", "--trials", "500", "--skip-throughput"], "bench_bank.txt"),
    (["bench_bank.py", "--skip-throughput", "--skip-reproduction", "--dt-sweep", "100"], "bench_bank.txt"),
    (["bench_bank.py", "--skip-throughput", "--skip-reproduction", "--default-set", "--real"], "bench_bank.txt"),
    (["bench_bank.py", "--skip-throughput", "--skip-reproduction", "--fig4", "100"], "bench_bank.txt"),
    (["reproduce_paper000.py", "--case", "4.1", "--runs", "200"], "reproduce_paper000.txt"),
    (["reproduce_paper000.py", "--case", "4.2", "--runs", "200"], "reproduce_paper000.txt"),
    (["reproduce_paper000.py", "--case", "4.3", "--runs", "200"], "reproduce_paper000.txt"),
    (["reproduce_paper000_sec5.py"], "reproduce_paper000.txt"),
    (["bench_coverage.py", "--runs", "100"], "bench_coverage.txt"),
    (["bench_allan_fit.py"], "bench_allan_fit.txt"),
    (["bench_allan_fit.py", "--runs", "30", "--duration", "600"], "bench_allan_fit.txt"),
    (["bench_allan_ci.py"], "bench_allan_ci.txt"),
    (["bench_cmkf_paper.py"], "bench_cmkf_paper.txt"),
    (["bench_cmkf_robot_sim.py"], "bench_cmkf_robot_sim.txt"),
    (["bench_cmkf_data.py"], "bench_cmkf_data.txt"),
    (["bench_cmkf_intervals.py"], "bench_cmkf_intervals.txt"),
    (["bench_node_husky.py"], "bench_node_husky.txt"),
    (["loop_measured.py", "--samples", "100000", "--mtig-samples", "100000"], "loop_measured.txt"),
    (["loop_measured.py", "--samples", "0"], "loop_measured.txt"),
    (["bench_rw_bound.py"], "bench_rw_bound.txt"),
    (["bench_random_walk.py", "--minutes", "20", "--cells", *RANDOM_WALK_CELLS, "--baseline", BASELINE],
     "bench_random_walk.txt"),
    (["bench_random_walk.py", "--minutes", "60", "--cells", *RANDOM_WALK_CELLS, "--baseline", BASELINE],
     "bench_random_walk.txt"),
    (["bench_random_walk.py", "--minutes", "180", "--cells", *RANDOM_WALK_CELLS, "--baseline", BASELINE],
     "bench_random_walk.txt"),
    (["bench_watch.py"], "bench_watch.txt"),
    (["bench_compare_adis.py"], "bench_compare_adis.txt"),
    (["bench_measured_passband.py", "--adis-runs", "1", "2", "3", "4", "5", "6", "--adis-samples", "30000"],
     "bench_measured_passband.txt"),
    (["bench_loop_effects.py"], "bench_loop_effects.txt"),
    (["bench_loop_effects.py", "--cases", "clean", "gm", "osc+gm", "bi", "osc+fast_gm", "osc+clear_gm"],
     "bench_loop_effects.txt"),
    (["bench_loop_effects.py", "--minutes", "120", "--cases", "osc+gm", "bi"], "bench_loop_effects.txt"),
    (["bench_loop_effects.py", "--clean", "10", "--minutes", "120", "--rate", "10",
      "--cases", "osc+gm", "gm", "osc+fast_gm", "osc+clear_gm", "clean"], "bench_loop_effects.txt"),
    (["bench_loop_effects.py", "--clean", "10", "--minutes", "1440", "--rate", "10",
      "--cases", "gm", "osc+gm", "clean", "bi"], "bench_loop_effects.txt"),
    (["bench_adis_analysis.py"], "bench_adis_analysis.txt"),
    (["bench_analyze_time.py", "--adis", "1", "--baseline", BASELINE, "--timeout", "1500", "--numbers",
      "--repeats", "3"], "bench_analyze_time.txt"),
    (["bench_analyze_time.py", "--adis", "1", "2", "3", "4", "5", "6", "--allow-motion", "--timeout", "1200"],
     "bench_analyze_time.txt"),
    (["bench_overbound.py"], "bench_overbound.txt"),
    (["bench_gmwm_speed.py"], "bench_gmwm_speed.txt"),
    (["bench_gmwm_accuracy.py"], "bench_gmwm_accuracy.txt"),
    (["bench_gmwm_robust.py"], "bench_gmwm_robust.txt"),
    (["bench_gmwm_pooled.py"], "bench_gmwm_pooled.txt"),
    (["bench_dlpf.py", "--rates", "200", "400", "--seeds", "1"], "bench_dlpf.txt"),
    (["bench_dlpf.py", "--rates", "1000", "--seeds", "1"], "bench_dlpf.txt"),
    (["bench_dlpf.py", "--rates", "1000", "--cutoffs", "5", "--orders", "2", "--variants", "RW", "--seeds", "10"],
     "bench_dlpf.txt"),
    (["bench_dlpf.py", "--rates", "200", "--cutoffs", "20", "--orders", "2", "--variants", "RW", "--seeds", "10"],
     "bench_dlpf.txt"),
]

#: Studies in bench/studies/ whose outputs README.md or docs/ quote (``--studies``; outputs in docs/results/studies/):
#: one-off questions, not regression numbers. The side-by-side studies against an old checkout are run by hand, their
#: last outputs kept as studies/bench_sensor_filter.txt and as sections of studies/likelihood_speed.txt
#: (bench_steady_engine, bench_loop_measured_time; bench_sin_regressors' and probe_inner_scaling's runs below write a
#: third and a fourth); the other studies keep no output: docs/ states what each found and names the script that
#: reproduces it.
STUDIES: list[tuple[list[str], str]] = [
    (["studies/probe_k_information.py", "--seeds", "3", "--minutes", "20", "120"], "studies/probe_k_information.txt"),
    (["studies/random_walk_bound.py"], "studies/probe_k_information.txt"),
    (["studies/bench_sin_regressors.py"], "studies/likelihood_speed.txt"),
    (["studies/probe_inner_scaling.py"], "studies/likelihood_speed.txt"),
    (["studies/composite_gap.py"], "studies/composite_gap.txt"),
    (["studies/whittle_shortfall.py", "--run", "1", "--axis", "gyro_x"], "studies/composite_gap.txt"),
    (["studies/watch_power_bound.py"], "bench_watch.txt"),
    (["studies/loop_trace.py", "1", "gyro_x", "--samples", "0"], "loop_measured.txt"),
    (["studies/loop_trace.py", "2", "accel_x", "--samples", "0"], "loop_measured.txt"),
]


def section_header(arguments: list[str]) -> str:
    """The line that heads a run's section in its output file: ``# python bench/SCRIPT ARGS``."""
    return f"# python bench/{' '.join(arguments)}"


def split_sections(text: str) -> tuple[str, dict[str, str]]:
    """A results file as (its text before the first section, {header: the section's text, header line included})."""
    preamble, sections, header = [], {}, None
    for line in text.splitlines(keepends=True):
        if line.startswith("# python bench/"):
            header = line.rstrip("\n")
            sections[header] = line
        elif header is None:
            preamble.append(line)
        else:
            sections[header] += line
    return "".join(preamble), sections


def replace_section(path: Path, header: str, section: str) -> None:
    """Write ``section`` into ``path`` in place of the section headed ``header`` (appended if it has none).

    The text before the file's first section (a note on all of them) is kept; a file with no section at all is
    replaced.
    """
    preamble, sections = split_sections(path.read_text() if path.exists() else "")
    if not sections:  # a file without sections is one earlier run's whole output
        preamble = ""
    sections[header] = section
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n\n".join(text.strip("\n") for text in [preamble, *sections.values()] if text.strip()) + "\n")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--long", action="store_true", help="also run the long reproductions")
    parser.add_argument("--studies", action="store_true", help="also run the studies of bench/studies/")
    parser.add_argument("--list", action="store_true", help="only list what would run")
    parser.add_argument("--only", nargs="+", metavar="SCRIPT",
                        help="run only these scripts (e.g. bench_allan.py bench_bags.py bench_analyze_memory.py)")
    parser.add_argument("--baseline", type=Path, default=BENCH.parents[1] / "baseline",
                        help="the checkout the speed goals compare with, side by side (default ../baseline; e.g. "
                             "git worktree add ../baseline 880642c, the checkout before the screen on statistics of "
                             "fixed size); without it the outputs that need it are left as they are")
    args = parser.parse_args(argv)
    jobs = GOALS + (LONG if args.long else []) + (STUDIES if args.studies else [])
    if args.only:
        jobs = [job for job in GOALS + LONG + STUDIES if Path(job[0][0]).name in args.only or job[0][0] in args.only]
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    env.setdefault("ROS_LOG_DIR", "/tmp/imu_noise_id_ros_log")
    failed = []
    if not args.baseline.is_dir():
        for arguments, out in jobs:
            if BASELINE in arguments:
                print(f"== {section_header(arguments)[2:]}: its section of docs/results/{out} left as it is, no "
                      f"baseline checkout at {args.baseline} (--baseline DIR)")
        jobs = [(arguments, out) for arguments, out in jobs if BASELINE not in arguments]
    for arguments, out in jobs:
        header = section_header(arguments)
        if args.list:
            print(f"{header[2:]}  -> docs/results/{out}")
            continue
        script = [str(args.baseline) if arg == BASELINE else arg for arg in arguments]
        print(f"== {header[2:]}  -> docs/results/{out}", flush=True)
        start = time.perf_counter()
        lines = [header + "\n"]
        # stdout is the section; stderr (progress, warnings, a traceback) goes to the console only
        proc = subprocess.Popen([sys.executable, str(BENCH / script[0]), *script[1:]], stdout=subprocess.PIPE,
                                env=env, cwd=BENCH.parent, text=True)
        for text in proc.stdout:  # printed here and kept in docs/results
            print(text, end="", flush=True)
            lines.append(text)
        proc.wait()
        replace_section(RESULTS / out, header, "".join(lines))
        print(f"== exit {proc.returncode} after {time.perf_counter() - start:.0f} s", flush=True)
        if proc.returncode != 0:
            failed.append(script[0])
    if failed:
        print(f"failed: {', '.join(failed)} (their errors are printed above)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
