"""The nonlinear quadrature of bent pairs (``sensorsel.information.integrity.nonlinear``) and what
shortens it: it counts the same wrong points as a direct count on every point, a pair it skips
because its bound is below the quadrature's resolution has no wrong point, and the pairs it ends
early move their keyframe's estimate by at most the stated share.

Oracles: a direct count of the nonlinear associator's decision on every point of the same Sobol set
(dense numpy, no prefilter, no subsets, matrix products by BLAS), the bound's gate term G_j(γ) (a
proved bound of P(NIS_j ≤ γ)), and the whole staged quadrature of every pair.
"""

from __future__ import annotations

import numpy as np
import pytest

from sensorsel.information.integrity import IntegritySpec, association, nonlinear, route_integrity
from sensorsel.information.linearize import bearing_range_jacobians

#: a stereo camera among long-range sensors in SLAM: fresh landmarks with metres of spread, bent pairs
SUITE = "LRR-7,HD2K-4,HD2K-9,LSC-2"


def _bent_calls(problem, monkeypatch) -> list[tuple]:
    """The arguments of every :func:`nonlinear.nonlinear_estimate` call of ``problem``'s SLAM integrity
    with :data:`SUITE` (the engine's own pairs), and their results."""
    calls = []
    real = nonlinear.nonlinear_estimate

    def spy(*args):
        out = real(*args)
        calls.append((args, out))
        return out

    with monkeypatch.context() as patch:
        patch.setattr(association, "nonlinear_estimate", spy)
        route_integrity(problem, problem.library.resolve_suite(SUITE), IntegritySpec(), map_sigma_m=None)
    return calls


def _direct(pairs, gate, reach, n_points):
    """(n, n_points) bool: the associator errs at each of the first ``n_points`` points of the Sobol
    set, each of the ``pairs`` computed on every point by the module docstring's model, plainly."""
    poses, point_i, point_j, z = pairs.poses, pairs.point_i, pairs.point_j, pairs.z
    noise_sd, cov, right = pairs.noise_sd, pairs.joint, pairs.right
    xi = nonlinear._normal_points()[:, :n_points]
    out = np.zeros((len(poses), n_points), bool)
    for p, pose in enumerate(np.asarray(poses, float)):
        c, s = np.cos(pose[2]), np.sin(pose[2])
        rot = np.array([[c, -s], [s, c]])
        e = nonlinear._cholesky(cov[p]) @ xi[:7]  # pose error (3), l_i's (2), l_j's (2)
        heading = pose[2] + e[2]
        zs = z[p][:, None] + xi[7:9] * noise_sd[p][:, None]
        reach_m = reach[0] * zs[1] + reach[1]
        r = np.diag(noise_sd[p] ** 2)

        def nis(point, e_l, jac, block):
            rel = (point - pose[:2])[:, None] + e_l - rot @ e[:2]
            nu = np.stack([zs[0] - np.arctan2(rel[1], rel[0]) + heading, zs[1] - np.hypot(rel[0], rel[1])])
            nu[0] = (nu[0] + np.pi) % (2.0 * np.pi) - np.pi
            s_inv = np.linalg.inv(r + jac @ cov[p][np.ix_(block, block)] @ jac.T)
            return np.einsum("in,ij,jn->n", nu, s_inv, nu), np.hypot(rel[0], rel[1])

        jac_i = bearing_range_jacobians(pose[None, :], point_i[p][None, :])[0]
        jac_j = bearing_range_jacobians(pose[None, :], point_j[p][None, :])[0]
        nis_j, dist_j = nis(point_j[p], e[5:7], jac_j, [0, 1, 2, 5, 6])
        wrong = (nis_j <= gate) & (dist_j <= reach_m)
        if right[p]:
            nis_i, dist_i = nis(point_i[p], e[3:5], jac_i, [0, 1, 2, 3, 4])
            wrong &= (nis_j < nis_i) | (nis_i > gate) | (dist_i > reach_m)
        out[p] = wrong
    return out


def _staged_rule(wrong: np.ndarray) -> np.ndarray:
    """The quadrature's stages applied to a direct count (``wrong`` (n, 2^SOBOL_LOG2)): the estimate
    at the first stage with 64 wrong points, or none from 2^13 points on; NaN where none errs."""
    out = np.full(len(wrong), np.nan)
    for p, row in enumerate(wrong):
        for m in nonlinear._STAGES:
            hits = int(np.count_nonzero(row[: 2**m]))
            if hits >= 64 or (hits == 0 and m >= 13):
                break
        out[p] = hits / 2**m if hits else np.nan
    return out


def test_the_quadrature_counts_what_a_direct_count_on_every_point_counts(tiny_problem, monkeypatch):
    """The quadrature skips the bearing where the range alone puts the candidate out of the gate, the
    right landmark's innovation where the candidate is out, and the factor's zeros: the same wrong
    points as the associator's decision computed on every point."""
    calls = _bent_calls(tiny_problem, monkeypatch)
    pairs, gate, reach = calls[0][0][4:]
    got = nonlinear.nonlinear_pair_probabilities(pairs, gate, reach)
    want = _staged_rule(_direct(pairs, gate, reach, n_points=2**nonlinear.SOBOL_LOG2))
    assert len(got) > 100 and np.isfinite(got).sum() > 20 and (~np.isfinite(got)).sum() > 20  # not vacuous
    assert pairs.right.any() and not pairs.right.all()  # right landmarks and first sightings both
    np.testing.assert_array_equal(got, want)


def test_a_pair_skipped_for_its_bound_has_no_wrong_point_in_the_whole_quadrature(tiny_problem, monkeypatch):
    """A bent pair whose bound term G_j(γ) is below the quadrature's resolution gets no quadrature: its
    estimate is min(linearized, G_j). The whole quadrature of each pair skipped so sees no wrong point
    (it would give no more than the resolution-capped linearized value either), and every estimate of
    a bent pair is at most its G_j (a proved bound of P(NIS_j ≤ γ) ≥ p_j). The keyframe's share is
    0 here, so that the resolution alone skips (the share's own test is the next)."""
    used = []  # the points each bent pair's quadrature used (0: skipped)
    real = nonlinear._staged

    def spy(*args):
        hits, points = real(*args)
        used.append(points)
        return hits, points

    monkeypatch.setattr(nonlinear, "_staged", spy)
    monkeypatch.setattr(nonlinear, "KEYFRAME_SHARE", 0.0)
    calls = _bent_calls(tiny_problem, monkeypatch)
    assert len(used) == len(calls)
    skipped = 0
    for (args, out), points in zip(calls, used):
        p, bent, _, bound = args[:4]
        g = bound[bent]
        skip = points == 0
        full = nonlinear.nonlinear_pair_probabilities(args[4].select(skip), *args[5:])
        assert np.isnan(full).all(), full[np.isfinite(full)]
        assert (g[skip] <= 2.0**-nonlinear.SOBOL_LOG2).all()
        np.testing.assert_array_equal(out[bent][skip], np.minimum(p[bent][skip], g[skip]))
        assert (out[bent] <= g).all()
        skipped += int(skip.sum())
    assert skipped >= 3  # not vacuous


@pytest.mark.parametrize("share", [0.02, 0.1])
def test_pairs_ended_early_move_each_keyframe_by_at_most_the_stated_share(suburb_problem, monkeypatch, share):
    """Against the whole quadrature of every bent pair (the share 0: each pair to the end of its
    stages), each keyframe's estimate moves by at most ``share`` of itself, and pairs did end early."""
    suite = suburb_problem.library.resolve_suite(SUITE)

    def estimate(value: float) -> np.ndarray:
        monkeypatch.setattr(nonlinear, "KEYFRAME_SHARE", value)
        r = route_integrity(suburb_problem, suite, IntegritySpec(), map_sigma_m=None)
        return np.asarray(r.p_wrong_association_estimate, float)

    full, fast = estimate(0.0), estimate(share)
    assert np.count_nonzero(fast != full) >= 5  # the rule ended pairs early: not vacuous
    assert (np.abs(fast - full) <= share * full).all(), np.max(np.abs(fast - full) / np.maximum(full, 1e-300))


def test_the_shortened_estimate_is_the_same_whatever_the_threads(tiny_problem):
    """Byte-identical for one thread and several, with pairs skipped and ended early."""
    from threadpoolctl import threadpool_limits

    suite = tiny_problem.library.resolve_suite(SUITE)
    runs = []
    for threads in (1, 4):
        with threadpool_limits(threads):
            r = route_integrity(tiny_problem, suite, IntegritySpec(), map_sigma_m=None)
        runs.append(np.asarray(r.p_wrong_association_estimate, float).tobytes())
    assert runs[0] == runs[1]


def test_the_quadrature_points_are_scipys_scrambled_sobol_points():
    """The quadrature's own Sobol generator (no scipy.stats import) gives scipy's points bit for bit."""
    from scipy.stats import qmc

    for d, log2n, seed in ((9, nonlinear.SOBOL_LOG2, nonlinear._SOBOL_SEED), (4, 6, 7), (1, 3, 0)):
        want = qmc.Sobol(d, scramble=True, seed=seed).random_base2(log2n)
        assert nonlinear._scrambled_sobol(d, log2n, seed).tobytes() == want.tobytes(), (d, log2n, seed)


@pytest.mark.parametrize("dtype", [np.float64, nonlinear.QUADRATURE_DTYPE])
@pytest.mark.parametrize(
    ("n_pairs", "n_points", "rows", "cols"), [(1, 24576, 2, 7), (3, 8192, 2, 7), (809, 512, 1, 3), (2048, 32, 2, 7)]
)
def test_the_grid_product_sums_in_the_order_written_out(n_pairs, n_points, rows, cols, dtype):
    """The quadrature's A ξ on the grid (np.einsum) against the sums written out, product by product in
    the order of the columns (the oracle), to the bit: the quadrature's numbers depend on no library's
    choice of order or fused multiply-adds. Coefficients over six decades and zero columns (the
    state's factor is lower triangular), as the quadrature's own."""
    rng = np.random.default_rng(n_pairs + n_points)
    a = rng.standard_normal((n_pairs, rows, cols)) * 10.0 ** rng.integers(-3, 3, (n_pairs, rows, cols))
    a[:, :, -1] *= rng.random((n_pairs, rows)) < 0.5
    xi = rng.standard_normal((cols, n_points))
    a, xi = a.astype(dtype), xi.astype(dtype)  # the quadrature's own precision, and double
    written = np.zeros((rows, n_pairs, n_points), dtype)
    for r in range(rows):
        for q in range(cols):
            written[r] += a[:, r, q, None] * xi[q]
    got = nonlinear._combine(a, xi, grid=True)
    assert got.shape == written.shape
    assert np.array_equal(got, written)
    assert (got == 0).sum() == (written == 0).sum()
