"""The bad-keyframe masks the windows' verdicts work on (:mod:`sensorsel.designs.requirements.truncated`)
against the verdict of the covariances themselves."""

from __future__ import annotations

import numpy as np
import pytest

from sensorsel.designs.requirements.spec import Specification, covariance_verdict
from sensorsel.designs.requirements.truncated import (
    bad_keyframes,
    mask_of_bad,
    meets_from_bad,
    meets_from_mask,
    over_limits,
)


def _covariances(rng: np.random.Generator, k: int) -> np.ndarray:
    """(k, 3, 3) random covariances, σ of about 0.05 m and 0.1° spread over a factor of ~3."""
    a = rng.normal(size=(k, 3, 3)) * np.array([0.03, 0.03, np.radians(0.06)])[:, None]
    return a @ np.transpose(a, (0, 2, 1)) + np.diag([1e-4, 1e-4, 1e-7])


@pytest.mark.parametrize("at", [1.0, 0.9, 0.5])
@pytest.mark.parametrize("seed", range(6))
def test_the_masks_judge_as_the_verdict(at, seed):
    """A suite meets the specification by its bad keyframes' mask exactly where the verdict of its
    covariances says so (the rank rule at ``at``), and the mask is the bad keyframes' sets."""
    rng = np.random.default_rng(seed)
    k = int(rng.integers(1, 60))
    cov = _covariances(rng, k)
    spec = Specification(lateral=0.1, longitudinal=0.12, heading=0.2, at=at)
    over = over_limits(cov, spec)
    assert over.shape == (3, k)
    bad = bad_keyframes(cov, spec)
    assert np.array_equal(mask_of_bad(bad, k), over)
    for i, (comp, bound, _) in enumerate(spec.bounds()):  # hand-written: σ of the component over its limit
        j = {"longitudinal": 0, "lateral": 1, "heading": 2}[comp]
        sigma = np.sqrt(cov[:, j, j]) * (np.degrees(1.0) if comp == "heading" else 1.0)
        assert np.array_equal(np.flatnonzero(spec.factor * sigma / bound - 1.0 > 0), bad[i])
    expected = covariance_verdict(cov, spec)[0]
    assert meets_from_mask(over, spec) == meets_from_bad(bad, k, spec) == expected
    chosen = np.sort(rng.choice(k, size=min(k, 5), replace=False))
    assert all(np.array_equal(b, chosen[row[chosen]]) for b, row in zip(bad_keyframes(cov, spec, chosen), over))


def test_the_slack_moves_the_test_off_the_limit():
    """A keyframe exactly at its limit is within it at slack 0, over it at a negative slack and
    within it at a positive one."""
    spec = Specification(lateral=0.1, at=1.0)
    sigma = 0.1 / spec.factor
    cov = np.diag([1e-6, sigma**2, 1e-9])[None]
    ratio = spec.factor * np.sqrt(cov[0, 1, 1]) / 0.1 - 1.0  # 0 to round-off
    assert over_limits(cov, spec, slack=abs(ratio) + 1e-12).sum() == 0
    assert over_limits(cov, spec, slack=-abs(ratio) - 1e-12).sum() == 1
