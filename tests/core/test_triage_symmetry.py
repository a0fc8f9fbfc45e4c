"""The symmetry of look-alike matches (core/triage/symmetry.py) on constructed point pairs."""

import numpy as np
import pytest

from guided_sfm.core.triage import symmetry


def scattered(rng, count, size=10.0):
    return rng.uniform(-size, size, (count, 2))


def test_a_known_turn_and_shift_is_recovered_among_outliers():
    rng = np.random.default_rng(1)
    truth = np.array([3.0, -1.5, np.radians(90.0)])
    moving = scattered(rng, 300)
    fixed = symmetry.apply(truth, moving) + rng.normal(0, 0.02, (300, 2))
    fixed[200:] = scattered(rng, 100)  # a third of the pairs say nothing
    found = symmetry.symmetry_of(moving, fixed, tolerance=0.2)
    assert found is not None
    assert found.motion[:2] == pytest.approx(truth[:2], abs=0.05)
    assert found.motion[2] == pytest.approx(truth[2], abs=np.radians(1.0))
    assert found.support >= 195 and found.runner_up < 20


def test_too_few_agreeing_pairs_give_none():
    rng = np.random.default_rng(2)
    moving = scattered(rng, 200)
    fixed = scattered(rng, 200)
    truth = np.array([1.0, 2.0, 0.5])
    fixed[:symmetry.MIN_SUPPORT - 5] = symmetry.apply(truth, moving[:symmetry.MIN_SUPPORT - 5])
    assert symmetry.symmetry_of(moving, fixed, tolerance=0.2) is None


def test_two_motions_equally_supported_are_ambiguous():
    """A shift and a half turn of a scene with two look-alike halves, each carried by as many
    pairs: the matches do not say which, so no symmetry is returned."""
    rng = np.random.default_rng(3)
    moving = scattered(rng, 200)
    shift, turn = np.array([4.0, 0.0, 0.0]), np.array([0.0, 0.0, np.pi])
    fixed = np.vstack([symmetry.apply(shift, moving[:100]), symmetry.apply(turn, moving[100:])])
    assert symmetry.symmetry_of(moving, fixed, tolerance=0.2) is None
    fixed[140:] = symmetry.apply(shift, moving[140:])  # now the shift has 4x the pairs
    found = symmetry.symmetry_of(moving, fixed, tolerance=0.2)
    assert found is not None and found.motion == pytest.approx(shift, abs=1e-6)
