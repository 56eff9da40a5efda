"""Golden outputs: the commands' result files on fixed seeds stay what they were (numbers to rounding).

Recorded before the architecture refactor (issue 10) so that moving code cannot change what users get. The inputs
are simulated here with fixed seeds, the commands run in-process, and every number in ``imu.yaml``, ``model.yaml``,
``cmkf.yaml``, ``hypotheses.yaml`` and ``criteria.json`` is compared with ``test/golden/``. A change of behaviour
that is meant (a fix, a better estimator) regenerates the files with ``python test/test_golden.py --write`` in the
same commit, whose message says why.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest
from golden_run import generate, load

GOLDEN = Path(__file__).resolve().parent / "golden"
#: Relative tolerance of numbers ("to rounding": the files hold 6 significant digits in places).
REL = 2e-5
#: Absolute tolerance for numbers that are ~0 (a rounded 0 against 1e-17).
ABS = 1e-12
#: Keys whose values depend on where and how fast the test runs (paths, timings), not on the computation.
VOLATILE = {"source", "source_hypotheses", "bag", "imu_samples_per_second", "replay_seconds"}


def differences(got: object, want: object, where: str = "") -> list[str]:
    """Where ``got`` differs from ``want``: numbers beyond REL/ABS, anything else not equal."""
    if isinstance(want, dict) and isinstance(got, dict):
        out = []
        for key in sorted(set(want) | set(got), key=str):
            if key in VOLATILE:
                continue
            if key not in got or key not in want:
                out.append(f"{where}/{key}: {'missing' if key not in got else 'unexpected'}")
            else:
                out += differences(got[key], want[key], f"{where}/{key}")
        return out
    if isinstance(want, list) and isinstance(got, list):
        if len(got) != len(want):
            return [f"{where}: {len(got)} items, expected {len(want)}"]
        return [d for i, (g, w) in enumerate(zip(got, want, strict=True)) for d in differences(g, w, f"{where}[{i}]")]
    numbers = (int, float)
    if isinstance(want, numbers) and isinstance(got, numbers) and not isinstance(want, bool):
        if math.isnan(want) and math.isnan(got):
            return []
        if got == want or math.isclose(got, want, rel_tol=REL, abs_tol=ABS):
            return []
        return [f"{where}: {got!r}, expected {want!r}"]
    return [] if got == want else [f"{where}: {got!r}, expected {want!r}"]


@pytest.mark.parametrize("name", ["analyze_imu.yaml", "analyze_model.yaml", "fit_model.yaml", "cmkf.yaml",
                                  "hypotheses.yaml", "criteria.json"])
def test_output_equals_the_golden_file(golden_run, name):
    found = differences(load(golden_run[name]), load(GOLDEN / name))
    assert not found, f"{name} differs from test/golden/{name}:\n" + "\n".join(found[:40])


def test_the_comparison_catches_a_changed_number():
    """The comparison itself: a relative change above REL in a nested number is reported, rounding is not."""
    want = {"a": [{"x": 1.0, "y": "s"}], "source": "/tmp/1"}
    assert differences({"a": [{"x": 1.0 + 0.1 * REL, "y": "s"}], "source": "/tmp/2"}, want) == []
    assert differences({"a": [{"x": 1.0 + 10 * REL, "y": "s"}], "source": "/tmp/1"}, want) == ["/a[0]/x: "
                                                                                             f"{1.0 + 10 * REL!r}, "
                                                                                             "expected 1.0"]
    assert differences({"a": [{"x": 1.0}]}, want) == ["/a[0]/y: missing"]


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python test/test_golden.py --write   (regenerates test/golden/ from the current code)")
    import shutil
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        GOLDEN.mkdir(exist_ok=True)
        for name, path in generate(Path(tmp)).items():
            shutil.copyfile(path, GOLDEN / name)
            print(f"wrote {GOLDEN / name}")
