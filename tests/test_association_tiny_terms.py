"""The bound's minimum over the levels t: a pair whose gate term G_j(γ) is below TINY_TERM takes it at
every t (G_j is non-decreasing in t). The oracle: the same bound with every pair's G_j(t) computed
(TINY_TERM 0). The shortcut must never lower the bound, and loosen it by no more than it claims."""

from __future__ import annotations

import numpy as np
import pytest

import sensorsel.information.integrity.association as association
from sensorsel.information.integrity import IntegritySpec, route_integrity


@pytest.mark.parametrize("map_sigma", [0.05, None])
def test_the_shortcut_keeps_a_bound_and_barely_moves_it(suburb_problem, monkeypatch, map_sigma):
    suite = suburb_problem.library.resolve_suite("LRR-7,HD2K-4,HD2K-9,LSC-2")
    fast = np.asarray(
        route_integrity(suburb_problem, suite, IntegritySpec(), map_sigma_m=map_sigma).p_wrong_association
    )
    monkeypatch.setattr(association, "TINY_TERM", 0.0)
    full = np.asarray(
        route_integrity(suburb_problem, suite, IntegritySpec(), map_sigma_m=map_sigma).p_wrong_association
    )
    assert np.all(fast >= full)  # still a bound: never below the one with every term computed
    # each measurement's minimum over t is above e^(−γ/2) where taken; a pair adds < TINY_TERM to it
    assert np.all(fast - full <= 1e-6 * np.maximum(full, 1e-300) + 1e-9)
    assert np.any(fast > full) or np.array_equal(fast, full)
