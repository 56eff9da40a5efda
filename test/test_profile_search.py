"""The search for a profile interval's end (core/estimation/em/profile_search.py) on signed roots r(d) of known shape:
each end lies within R_TOL of r = Z95, and from no more profile points than the shape needs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_noise_id.core.estimation.em.profile_search import R_TOL, Z95, centre, end

SHAPES = {
    "linear (a quadratic log-likelihood)": lambda d: 1.2 * d,
    "convex": lambda d: d + 0.2 * d * d,
    "concave": lambda d: 2.2 * math.sqrt(d),
    "steep": lambda d: 1.9 * d**1.5,
}


def _end(r_of_d, known: list[float], first: float = 1.0) -> tuple[float, int]:
    """(end, profile points evaluated) of ``end`` in the + direction from the maximum at 0 (ℓ_A = −r²/2) and points
    already ``known`` at those distances."""
    calls = []

    def profile_at(v: float, starts: list[np.ndarray]) -> tuple[float, np.ndarray]:
        calls.append(v)
        return -0.5 * r_of_d(v) ** 2, np.zeros(1)

    pts = [(0.0, 0.0, np.zeros(1))] + [(d, -0.5 * r_of_d(d) ** 2, np.zeros(1)) for d in known]
    return end(profile_at, lambda th: [th], pts, 1.0, first=first, limit=100.0), len(calls)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("known", [[], [0.8], [1.0]])
def test_each_end_is_where_the_signed_root_is_z95(shape, known):
    r_of_d = SHAPES[shape]
    v_end, points = _end(r_of_d, known)
    assert abs(r_of_d(v_end) - Z95) < R_TOL
    assert points <= 3


def test_a_known_point_on_the_end_is_the_end():
    """The centre's points lie at the Wald ends: where one of them is within R_TOL already, it is the end, without
    another profile point (one more was evaluated)."""
    r_of_d = SHAPES["concave"]
    assert abs(r_of_d(0.8) - Z95) < R_TOL
    assert _end(r_of_d, [0.8]) == (0.8, 0)


def test_a_point_just_inside_the_end_steps_where_the_secant_puts_it():
    """From a point a little inside (r within SECANT_TRUSTED of Z95) the secant's prediction is the next point, not
    one at least 1.25× further that overshoots and needs regula falsi: one point where it took two."""
    r_of_d = SHAPES["steep"]
    assert Z95 - 0.25 < r_of_d(1.0) < Z95
    v_end, points = _end(r_of_d, [1.0])
    assert points == 1 and abs(r_of_d(v_end) - Z95) < R_TOL


def test_known_points_at_the_same_distance_and_height_are_ordered_without_comparing_their_argmaxes():
    """Two known points with the same (v, ℓ_A) — a profile evaluated twice at one v — sorted as tuples compared their
    argmax arrays next, and an argmax of more than one parameter raised ValueError ("truth value of an array …"): a
    traceback from ``fit``'s intervals on a WN+OSC+RW record. Points are ordered by distance and root alone."""
    def profile_at(v: float, starts: list[np.ndarray]) -> tuple[float, np.ndarray]:
        return -0.5 * (1.2 * v) ** 2, np.array([v, 1.0])

    twice = (2.0, -0.5 * 2.4**2)
    pts = [(0.0, 0.0, np.zeros(2)), (*twice, np.array([2.0, 1.0])), (*twice, np.array([2.0, 3.0]))]
    v_end = end(profile_at, lambda th: [th], pts, 1.0, first=1.0, limit=100.0)
    assert abs(1.2 * v_end - Z95) < R_TOL


def _centre(v_hat: float, steps: list[float], vertex: float) -> list:
    """``centre`` with the parabola, on ℓ_A = −(v − vertex)²/2."""
    def profile_at(v: float, starts: list[np.ndarray]) -> tuple[float, np.ndarray]:
        return -0.5 * (v - vertex) ** 2, np.zeros(1)

    return centre(profile_at, v_hat, -0.5 * (v_hat - vertex) ** 2, np.zeros(1), steps, predict=lambda _: [],
                  parabola=True)


def test_the_centres_parabola_finds_the_vertex_inside_its_points():
    pts = _centre(0.0, [-1.0, 1.0], 0.3)
    assert len(pts) == 4 and pts[-1][0] == pytest.approx(0.3, abs=1e-9)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("steps", [[-1e-300, 1e-300], [-1e-170, 1e-170], [1.0, 1.0]])
def test_the_centres_parabola_is_skipped_quietly_where_its_points_do_not_determine_one(steps):
    """Steps below the reach of squares (a slope whose standard error is ~0 gave ±1.96e-300) or repeated left the
    parabola's fit rank-deficient: numpy warned "Polyfit may be poorly conditioned" (or divided by zero) on the
    console, and the vertex was noise. No vertex is evaluated then, and nothing is warned."""
    pts = _centre(0.0, steps, 0.3 * steps[-1])
    assert len(pts) == 3
