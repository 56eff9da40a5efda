"""Markdown before/after table from the output of bench/loop_measured.py.

Usage: python bench/loop_measured_table.py docs/results/loop_measured.txt > docs/results/loop_measured_table.md
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

KEYWORDS = (
    ("innovation(s) beyond", "OUTLIERS"), ("spectral line", "SIN"), ("level shift", "STEP"),
    ("innovations correlated", "GM (Ljung–Box)"), ("model AV above the data", "GM (bounded long-τ AV)"),
    ("AV bump", "GM (AV bump)"), ("AV above the model at short", "QN"), ("AV above the model at long", "RW/RR"),
    ("temperature", "TEMP"), ("ramp", "RR"),
)
STEP = re.compile(r"^(\S+)\s+(\d+) (\S+)\s+(-?[\d.]+)\s+(-?[\d.]+)\s+([\d.]+)\s+(\S+)\s+([\d.]+)")


def main(path: str) -> int:
    cases: dict[str, dict] = {}
    for line in Path(path).read_text().splitlines():
        m = STEP.match(line)
        if m:
            name, idx, model, ll, bic, av, lb, peak = m.groups()
            case = cases.setdefault(name, {"steps": [], "verdict": "", "unexplained": []})
            case["steps"].append((int(idx), model, float(ll), float(bic), float(av), float(lb), float(peak)))
            continue
        parts = line.split(None, 1)
        if len(parts) == 2 and parts[0] in cases:
            rest = parts[1].strip()
            if rest.startswith("verdict:"):
                cases[parts[0]]["verdict"] = rest.removeprefix("verdict: ")
            elif rest.startswith("unexplained:"):
                text = rest.removeprefix("unexplained: ")
                cases[parts[0]]["unexplained"].append(next((e for k, e in KEYWORDS if k in text), text[:40]))
    print("| case | start → final model | ΔBIC | AV misfit | Ljung–Box p | peak ratio | verdict | still significant |")
    print("|---|---|---|---|---|---|---|---|")
    for name, c in cases.items():
        first, last = c["steps"][0], c["steps"][-1]
        left = "; ".join(dict.fromkeys(c["unexplained"])) or "—"
        verdict = c["verdict"].split(":")[0].split(";")[0]
        print(f"| {name} | {first[1]} → {last[1]} | {last[3] - first[3]:.0f} | {first[4]:.3f} → {last[4]:.3f} | "
              f"{first[5]:.2g} → {last[5]:.2g} | {first[6]:.0f} → {last[6]:.0f} | {verdict} | "
              f"{left} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1]))
