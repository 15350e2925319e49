"""What each sensor sees: hand-placed landmarks around hand-placed car poses, and a brute-force
per-landmark check of the vectorised cone test."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sensorsel.model.scenario import Scenario, Trajectory
from sensorsel.model.sensing import in_cone, observe, relative_geometry


def scene(poses, landmarks) -> Scenario:
    """A hand-built scenario: car poses (x, y, heading) and landmark positions."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    k = len(poses)
    return Scenario("hand", Trajectory(poses, np.arange(k, dtype=float), np.arange(k)), np.asarray(landmarks, float))


def seen(library, scenario, sensor_id) -> list[tuple[int, int]]:
    """(keyframe, landmark) pairs the sensor measures."""
    pos = library.position(sensor_id)
    obs = observe(library.subset([pos]), scenario)[0]
    return sorted(zip(obs.pose.tolist(), obs.landmark.tolist()))


def polar(r, deg, origin=(0.0, 0.0)):
    return [origin[0] + r * math.cos(math.radians(deg)), origin[1] + r * math.sin(math.radians(deg))]


def test_front_long_range_radar_hand_geometry(library):
    lrr = library[library.position("LRR-12")].model
    assert (lrr.fov_rad, lrr.range_m) == (0.0698, 250)
    lm = [
        [100.0, 0.0],  # 0: 100 m ahead -> seen
        [-100.0, 0.0],  # 1: 100 m behind
        polar(100, 10),  # 2: 10 degrees off-axis (the cone is +-2 degrees)
        [260.0, 0.0],  # 3: beyond 250 m
        polar(100, -10),  # 4: 10 degrees off-axis on the other side
        polar(249, 1.9),  # 5: inside both range and cone
        [250.0, 0.0],  # 6: exactly at maximum range (boundary counts)
    ]
    assert seen(library, scene([0, 0, 0], lm), "LRR-12") == [(0, 0), (0, 5), (0, 6)]
    # the same radar at 6 o'clock sees only the one behind
    assert seen(library, scene([0, 0, 0], lm), "LRR-6") == [(0, 1)]


def test_cone_edges(library):
    s = library[library.position("MRR-12")]
    half = 0.5 * s.model.fov_rad
    brg = np.array([half - 1e-9, -(half - 1e-9), half + 1e-6, -(half + 1e-6), 0.0, 0.0])
    rng = np.array([100.0, 100.0, 100.0, 100.0, 160.0, 160.0 + 1e-6])
    np.testing.assert_array_equal(in_cone(s, brg, rng), [True, True, False, False, True, False])


def test_three_oclock_sensor_sees_the_cars_right(library):
    lm = [[0.0, -100.0], [0.0, 100.0], [100.0, 0.0]]  # right, left, ahead of a car heading along +x
    sc = scene([0, 0, 0], lm)
    assert seen(library, sc, "LRR-3") == [(0, 0)]
    assert seen(library, sc, "LRR-9") == [(0, 1)]
    assert seen(library, sc, "LRR-12") == [(0, 2)]
    assert seen(library, sc, "MRR-4") == []  # 4 o'clock faces 30 degrees behind the right: nothing there


def test_cone_turns_with_the_car(library):
    # car at (50, 20) heading 90 degrees (along +y): ahead is +y, its right is +x
    car = [50.0, 20.0, math.pi / 2]
    lm = [[50.0, 120.0], [150.0, 20.0], [-50.0, 20.0], [50.0, -80.0], [150.0, 120.0]]
    sc = scene(car, lm)
    assert seen(library, sc, "LRR-12") == [(0, 0)]
    assert seen(library, sc, "LRR-3") == [(0, 1)]
    assert seen(library, sc, "LRR-9") == [(0, 2)]
    assert seen(library, sc, "LRR-6") == [(0, 3)]
    # 1:30 is not a clock position; the landmark at 45 degrees to the right is in no radar's cone
    for clock in range(1, 13):
        assert (0, 4) not in seen(library, sc, f"LRR-{clock}")
    # ... but a wide camera at 1 or 2 o'clock sees it if in range: move it closer (45 deg right, 30 m)
    sc2 = scene(car, [[50 + 30 / math.sqrt(2), 20 + 30 / math.sqrt(2)]])
    assert seen(library, sc2, "WSC-1") == [(0, 0)] and seen(library, sc2, "WSC-2") == [(0, 0)]
    assert seen(library, sc2, "WSC-11") == []


def test_cone_across_the_plus_minus_pi_seam(library):
    # heading just below +pi; a landmark just past -pi (the same direction, 2 degrees further)
    h = math.radians(179.5)
    lm = [polar(100, 181.0, origin=(10.0, 10.0)), polar(100, 184.0, origin=(10.0, 10.0))]
    sc = scene([10.0, 10.0, h], lm)
    assert seen(library, sc, "LRR-12") == [(0, 0)]  # 1.5 degrees off-axis
    sc_neg = scene([10.0, 10.0, -h], [polar(100, -181.0, origin=(10.0, 10.0))])
    assert seen(library, sc_neg, "LRR-12") == [(0, 0)]


def test_lidar_sees_everything_within_range(library):
    rng = np.random.default_rng(3)
    lm = rng.uniform(-180, 180, (400, 2))
    car = [5.0, -3.0, 0.7]
    d = np.hypot(lm[:, 0] - car[0], lm[:, 1] - car[1])
    sc = scene(car, lm)
    assert [j for _, j in seen(library, sc, "LRL-roof")] == np.flatnonzero(d <= 120).tolist()
    assert [j for _, j in seen(library, sc, "MRL-roof")] == np.flatnonzero(d <= 100).tolist()
    assert 0 < np.sum(d <= 100) < np.sum(d <= 120) < len(lm)


def test_measurements_and_their_noise(library):
    car = [3.0, 4.0, 0.3]
    lm = [
        polar(10.0, math.degrees(0.3) + 5.0, origin=(3.0, 4.0)),
        polar(40.0, math.degrees(0.3) - 20.0, origin=(3.0, 4.0)),
    ]
    sc = scene(car, lm)
    pos = [library.position(i) for i in ("WSC-12", "LRR-12", "LRL-roof")]
    obs = observe(library.subset(pos), sc)
    wsc, lrr, lrl = obs
    assert wsc.landmark.tolist() == [0, 1] and lrr.landmark.tolist() == [] and lrl.landmark.tolist() == [0, 1]
    np.testing.assert_allclose(wsc.range_m, [10.0, 40.0], rtol=1e-12)
    np.testing.assert_allclose(wsc.bearing_rad, np.radians([5.0, -20.0]), atol=1e-12)
    # stereo: range noise z^2 / (f b) sigma_d, bearing sigma_px / f (Table I: f = 721.5377 px, b = 0.5371 m)
    np.testing.assert_allclose(wsc.sigma_range_m, np.array([10.0, 40.0]) ** 2 / (721.5377 * 0.5371) * 0.5, rtol=1e-12)
    np.testing.assert_allclose(wsc.sigma_bearing_rad, 1.0 / 721.5377, rtol=1e-12)
    np.testing.assert_allclose(lrl.sigma_range_m, 0.084)
    np.testing.assert_allclose(lrl.sigma_bearing_rad, 0.00110)
    assert [o.sensor for o in obs] == [0, 1, 2]  # positions in the library observed


def test_observe_matches_a_brute_force_loop(library):
    """Every (sensor, keyframe, landmark) decided one at a time with math.atan2 and plain loops."""
    rng = np.random.default_rng(12)
    poses = np.column_stack([rng.uniform(-50, 50, 6), rng.uniform(-50, 50, 6), rng.uniform(-np.pi, np.pi, 6)])
    lm = rng.uniform(-200, 200, (120, 2))
    sc = scene(poses, lm)
    obs = observe(library, sc)
    assert len(obs) == 62
    for i, s in enumerate(library):
        expect = []
        for k, (x, y, th) in enumerate(poses):
            for j, (lx, ly) in enumerate(lm):
                r = math.hypot(lx - x, ly - y)
                facing = th + s.mount_angle_rad
                off = math.atan2(
                    math.sin(math.atan2(ly - y, lx - x) - facing), math.cos(math.atan2(ly - y, lx - x) - facing)
                )
                if r <= s.model.range_m and (s.model.fov_rad >= 2 * math.pi or abs(off) <= s.model.fov_rad / 2):
                    expect.append((k, j))
        got = list(zip(obs[i].pose.tolist(), obs[i].landmark.tolist()))
        assert got == expect, s.id
    total = sum(len(o) for o in obs)
    assert total > 100  # the scene exercises the cones


def test_relative_geometry_shapes_and_values():
    sc = scene([[0, 0, 0], [1, 1, math.pi / 2]], [[3.0, 4.0], [1.0, 3.0], [-1.0, 1.0]])
    brg, rng = relative_geometry(sc)
    assert brg.shape == rng.shape == (2, 3)
    np.testing.assert_allclose(rng[0], [5.0, math.sqrt(10), math.sqrt(2)])
    np.testing.assert_allclose(rng[1], [math.sqrt(13), 2.0, 2.0])
    np.testing.assert_allclose(brg[1, 1], 0.0, atol=1e-12)  # straight ahead of the car facing +y
    np.testing.assert_allclose(brg[1, 2], math.pi / 2, atol=1e-12)  # to its left
    assert np.all((brg >= -np.pi) & (brg < np.pi))


def test_landmark_at_the_car_is_not_measured(library):
    sc = scene([2.0, 2.0, 0.0], [[2.0, 2.0], [10.0, 2.0]])
    assert seen(library, sc, "LRL-roof") == [(0, 1)]


@pytest.mark.parametrize("fixture_name", ["tiny_problem", "suburb_problem"])
def test_fixture_observations_are_consistent(request, fixture_name):
    p = request.getfixturevalue(fixture_name)
    for o in p.observations:
        n = len(o)
        for a in (o.pose, o.landmark, o.bearing_rad, o.range_m, o.sigma_bearing_rad, o.sigma_range_m):
            assert a.shape == (n,)
        assert np.all(o.sigma_range_m > 0) and np.all(o.sigma_bearing_rad > 0)
        # sorted by (pose, landmark)
        key = o.pose * (p.scenario.n_landmarks + 1) + o.landmark
        assert np.all(np.diff(key) > 0)
    lidar = p.observations[p.library.position("LRL-roof")]
    assert len(lidar) > 0


def test_landmarks_nearer_than_the_minimum_range_are_not_measured(library):
    # a pole of a real map lying on the route, 0.1 m from a keyframe, stands inside the car: measuring
    # it would add a bearing information ~1/r^2 (here 100x that of a pole at 1 m), an artifact
    from sensorsel.information.evaluators import make_evaluator
    from sensorsel.model.problem import build_problem
    from sensorsel.model.sensing import MIN_RANGE_M

    lidar = library.subset([library.position("LRL-roof")])
    kf = Trajectory(np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]]), np.array([0.0, 1.0]), np.arange(2))
    for r, seen in ((0.1, False), (MIN_RANGE_M - 1e-6, False), (MIN_RANGE_M, True), (2.0, True)):
        sc = Scenario("near", kf, np.array([[10.0 + r, 0.0]]))
        obs = observe(lidar, sc)[0]
        assert (1 in obs.pose.tolist()) == seen, r
    # however near the pole, the suite's score stays finite: the far keyframe's measurement only
    near = build_problem(lidar, Scenario("near", kf, np.array([[10.0 + 1e-6, 0.0]])))
    assert near.observations[0].pose.tolist() == [0]
    assert math.isfinite(make_evaluator(near, "reference").score([0])) and make_evaluator(near, "fast").score([0]) > 0


def test_off_axis_is_the_angle_between_bearing_and_axis():
    # oracle: the angle between two unit vectors, from atan2 per element (no wrapping arithmetic)
    from sensorsel.model.angles import wrap_angle
    from sensorsel.model.sensing import off_axis

    rng = np.random.default_rng(3)
    bearings = wrap_angle(rng.uniform(-10.0, 10.0, 2000))
    for mount in (0.0, math.pi, -math.pi, 0.5, -2.9, 3.0 * math.pi / 2, 7.0):
        want = [abs(math.atan2(math.sin(b - mount), math.cos(b - mount))) for b in bearings]
        got = off_axis(bearings, mount)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        assert np.all((got >= 0) & (got <= math.pi + 1e-15))
