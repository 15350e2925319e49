"""wrap_angle: bit for bit numpy's ``(a + π) % 2π − π`` (the rule it replaces, the oracle), on the
common range its fast path takes, on its edges, and on angles beyond it (which must take ``%``)."""

from __future__ import annotations

import numpy as np
import pytest

from sensorsel.model.angles import wrap_angle


def _oracle(a: np.ndarray) -> np.ndarray:
    return (np.asarray(a, float) + np.pi) % (2.0 * np.pi) - np.pi


def _same_bits(a: np.ndarray) -> bool:
    return np.asarray(wrap_angle(a)).tobytes() == np.asarray(_oracle(a)).tobytes()


def test_bearing_differences_bit_for_bit() -> None:
    rng = np.random.default_rng(7)
    # a bearing less a bearing plus a heading: the quadrature's innovations, the fast path's range
    a = rng.uniform(-np.pi, np.pi, 200_000) - rng.uniform(-np.pi, np.pi, 200_000) + rng.uniform(-np.pi, np.pi, 200_000)
    assert _same_bits(a)
    assert _same_bits(rng.uniform(-1e-12, 1e-12, 1000))  # tiny angles, where x + 2π rounds


def test_edges_of_the_fast_path() -> None:
    two_pi = 2.0 * np.pi
    edges = [x - np.pi for x in (0.0, two_pi, 2.0 * two_pi, -two_pi)]
    near = [np.nextafter(x, d) for x in edges for d in (-np.inf, np.inf)]
    for a in [*edges, *near, 0.0, -0.0, np.pi, -np.pi]:
        assert _same_bits(np.array([a])), a
        assert _same_bits(np.array(a)), a  # 0-d


@pytest.mark.parametrize("far", [3.0 * np.pi + 0.1, -3.0 * np.pi, 50.0, -1e6, 1e300, np.inf, np.nan])
def test_angles_beyond_the_fast_path_take_the_remainder(far: float) -> None:
    rng = np.random.default_rng(3)
    a = rng.uniform(-np.pi, np.pi, 1000)
    a[500] = far  # one angle beyond (−3π, 3π) in an array of ordinary ones
    with np.errstate(invalid="ignore"):
        assert _same_bits(a)


def test_single_precision_stays_single_bit_for_bit() -> None:
    """float32 (the association quadrature's bearings) in, float32 out, bit for bit the rule in float32
    (π and 2π rounded to it), on the fast path's range, its edges and beyond it."""
    rng = np.random.default_rng(11)
    pi, two_pi = np.float32(np.pi), np.float32(2.0 * np.pi)
    a = (rng.uniform(-np.pi, np.pi, 100_000) * 2.9).astype(np.float32)
    edges = np.array([-pi, pi, two_pi + pi, -two_pi - pi, 0.0, -0.0], np.float32)
    near = np.concatenate([np.nextafter(edges, np.float32(-np.inf)), np.nextafter(edges, np.float32(np.inf))])
    for x in (a, edges, near, np.array([1e6, -50.0, 3.5 * np.pi], np.float32)):
        got = wrap_angle(x)
        assert got.dtype == np.float32
        assert got.tobytes() == ((x + pi) % two_pi - pi).tobytes()
