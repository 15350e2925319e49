"""Every keyframe's association risks computed at once equal each keyframe's computed alone.

The reference is the per-keyframe computation as it was before the batch
(``association_reference``: each keyframe's risks from its whole predicted covariance, during the
forward pass). The batch must give the same numbers, bit for bit: the bound, its linearized form,
the candidates and the estimate of every measurement, and what :func:`route_integrity` and the
search's association floor make of them.
"""

from __future__ import annotations

import association_reference as ref
import numpy as np
import pytest

from sensorsel.information.filtering import forward_pass
from sensorsel.information.integrity import (
    AssociationModel,
    IntegrityBounds,
    IntegritySpec,
    association,
    route_integrity,
)

#: a stereo camera among long-range sensors: many candidates, wide SLAM spreads, first sightings
SUITES = ("LRR-7,HD2K-4,HD2K-9,LSC-2", "LRR-1,MRR-3,HD2K-1,LSC-12")


def _per_keyframe(problem, suite, map_sigma, **kw):
    """(predictions, measurements, the reference's risks) of every keyframe with measurements."""
    model = "slam" if map_sigma is None else "map"
    old = ref.AssociationModel(problem, model=model)
    preds, metas, risks = [], [], []

    def observe(pred, meas):
        if len(meas.landmark):
            preds.append(pred)
            metas.append(meas)
            risks.append(old.risks(pred, meas, **kw))

    forward_pass(problem, suite, map_sigma_m=map_sigma, on_prediction=observe)
    return preds, metas, risks


@pytest.mark.parametrize("suite_ids", SUITES)
@pytest.mark.parametrize("map_sigma", [0.05, None])
@pytest.mark.parametrize(
    "kw", [{}, {"linear": True}, {"robust_to_covariance": True}], ids=["plain", "linear", "robust"]
)
def test_batched_risks_equal_each_keyframe_alone(suburb_problem, suite_ids, map_sigma, kw):
    problem = suburb_problem
    suite = problem.library.resolve_suite(suite_ids)
    preds, metas, risks = _per_keyframe(problem, suite, map_sigma, **kw)
    model = AssociationModel(problem, model="slam" if map_sigma is None else "map")
    got = model.risks_of([model.snapshot(p, m) for p, m in zip(preds, metas)], **kw)
    for field in ("bound", "linear", "n_candidates", "estimate"):
        want = np.concatenate([getattr(r, field) for r in risks])
        np.testing.assert_array_equal(getattr(got, field), want, err_msg=field)
    # the case is not empty: risky measurements and candidates to compare
    assert np.count_nonzero(got.bound > 1e-6) > 10 and got.n_candidates.sum() > 100
    # and one keyframe alone through the batch (what the lever computes) gives the same again
    k = int(np.argmax([r.bound.max() for r in risks]))
    alone = model.risks(preds[k], metas[k], **kw)
    np.testing.assert_array_equal(alone.bound, risks[k].bound)
    np.testing.assert_array_equal(alone.estimate, risks[k].estimate)


def _reference_integrity(problem, suite, map_sigma, threshold):
    """(bound, estimate) per keyframe as the per-keyframe hook computed them during the pass."""
    old = ref.AssociationModel(problem, model="slam" if map_sigma is None else "map")
    bound, estimate = np.zeros(problem.scenario.n_poses), np.zeros(problem.scenario.n_poses)

    def use(pred, meas):
        r = old.risks(pred, meas)
        mask = np.ones(len(meas.landmark), bool) if threshold is None else r.bound <= threshold
        estimate[meas.keyframe], bound[meas.keyframe] = ref.keyframe_risk(r.estimate[mask], r.bound[mask])
        return mask

    fp = forward_pass(problem, suite, map_sigma_m=map_sigma, use=use)
    return bound, estimate, fp.n_used


@pytest.mark.parametrize("map_sigma", [0.05, None])
@pytest.mark.parametrize("threshold", [None, 1e-3])
@pytest.mark.parametrize("small", [False, True], ids=["one-batch", "small-batches"])
def test_route_integrity_equals_the_per_keyframe_hook(suburb_problem, map_sigma, threshold, small, monkeypatch):
    """``small``: keyframes computed in groups of a few hundred pairs, a few snapshots at a time."""
    if small:
        monkeypatch.setattr(association, "PAIRS_PER_BATCH", 300)
        monkeypatch.setattr(association, "PENDING_BYTES", 20_000)
    problem = suburb_problem
    suite = problem.library.resolve_suite(SUITES[0])
    bound, estimate, n_used = _reference_integrity(problem, suite, map_sigma, threshold)
    r = route_integrity(problem, suite, IntegritySpec(max_association_risk=threshold), map_sigma_m=map_sigma)
    np.testing.assert_array_equal(r.p_wrong_association, bound)
    np.testing.assert_array_equal(r.p_wrong_association_estimate, estimate)
    np.testing.assert_array_equal(r.n_used, n_used)
    assert max(bound) > 1e-4
    if threshold is not None:  # the lever left measurements out, and the reference agrees where
        assert sum(x.count for x in r.left_out) == sum(r.n_measured) - int(n_used.sum()) > 0


@pytest.mark.parametrize("threshold", [None, 1e-3])
def test_association_floor_equals_the_per_keyframe_one(suburb_problem, threshold):
    problem = suburb_problem
    allowed = range(0, problem.n_sensors, 5)
    spec = IntegritySpec(max_association_risk=threshold)
    floor = np.zeros((problem.n_sensors, problem.scenario.n_poses))
    old = ref.AssociationModel(problem, model="map", gate_probability=spec.gate_probability)
    priors = []
    forward_pass(problem, (), map_sigma_m=0.05, on_prediction=lambda p, m: priors.append(p))
    # the floor reads bounds only: neither side computes the estimate
    preds, metas, risks = _per_keyframe(problem, allowed, 0.05, linear=True, estimate=False)
    for p, m, r in zip(preds, metas, risks):
        b = r.linear
        if threshold is not None:
            upper = old.risks(priors[p.keyframe], m, robust_to_covariance=True, estimate=False).bound
            b = np.where(upper <= threshold, b, 0.0)
        np.add.at(floor[:, p.keyframe], m.sensor, b)
    got = IntegrityBounds(problem, allowed, spec, map_sigma_m=0.05).floor
    np.testing.assert_array_equal(got, floor)
    assert floor.max() > 1e-9 and np.count_nonzero(floor) > 5
