"""An answer a team can sign: the margin (smallest slack, where, binding keyframes) and the ties,
on cases worked by hand; --margin demands the specification with that much to spare; a route
without a landmark file is refused unless invented landmarks are accepted."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.designs.requirements import Specification, cheapest_suite, verdict
from sensorsel.designs.requirements.margin import margin_of
from sensorsel.designs.requirements.spec import covariance_verdict
from sensorsel.information.evaluators.accuracy import accuracy_from_covariances
from sensorsel.model.constraints import Constraints, feasible_set

#: four keyframes: 1σ longitudinal, lateral [m], heading [deg]
LAT = [0.05, 0.095, 0.0955, 0.08]
HEAD = [0.16, 0.10, 0.12, 0.11]


def _accuracy():
    cov = np.zeros((4, 3, 3))
    cov[:, 0, 0] = 0.01**2
    cov[:, 1, 1] = np.square(LAT)
    cov[:, 2, 2] = np.square(np.radians(HEAD))
    return cov, accuracy_from_covariances(cov, map_sigma_m=0.05, route="r")


def test_margin_every_keyframe_by_hand():
    """1σ bounds 0.1 m lateral, 0.17 deg heading: lateral slacks 0.05, 0.005, 0.0045, 0.02 m
    (4.5 % of the limit at keyframe 2), heading 0.01 deg at best (5.9 %): lateral binds, at
    keyframe 2, with keyframe 1 (0.0005 m away, within 1 % of the limit)."""
    _, acc = _accuracy()
    m = margin_of([("r", Specification(lateral=0.1, heading=0.17, sigma=True), acc)])
    assert (m.route, m.component, m.keyframe, m.unit) == ("r", "lateral", 2, "m")
    assert m.slack == pytest.approx(0.0045) and m.slack_share == pytest.approx(0.045)
    assert m.binding_keyframes == (1, 2)


def test_margin_at_a_share_of_keyframes_by_hand():
    """At 50 % of the keyframes (the 2nd smallest of 4): lateral 0.08 m at keyframe 3 (20 % to
    spare), heading 0.11 deg at keyframe 3 (35.3 %): lateral binds at keyframe 3."""
    _, acc = _accuracy()
    m = margin_of([("r", Specification(lateral=0.1, heading=0.17, sigma=True, at=0.5), acc)])
    assert (m.component, m.keyframe) == ("lateral", 3) and m.slack_share == pytest.approx(0.2)


def test_a_demanded_margin_tightens_every_bound():
    """With 5 % to spare the lateral 0.0955 m of a 0.1 m bound fails (more than 0.095 m), with 4 % it
    passes; the covariance verdict agrees with the full one."""
    cov, acc = _accuracy()
    for margin, meets in ((0.05, False), (0.04, True)):
        spec = Specification(lateral=0.1, sigma=True, margin=margin)
        assert verdict(acc, spec).meets is meets
        assert covariance_verdict(cov, spec) == (verdict(acc, spec).meets, verdict(acc, spec).violation)


def test_ties_by_hand(library):
    """meets(S): S holds one of three sensors of one price: the cheapest is one of them and the
    other two are its ties; the tie search runs out of suites (exhaustive). Without the tie search
    only ties met on the way are reported and the list is not called exhaustive."""
    keep = [i for i, c in enumerate(library.costs) if c == library.costs[14]][:3]
    fs = feasible_set(library, math.inf, Constraints())
    trio = set(keep)
    r = cheapest_suite(fs, lambda s: bool(trio & set(s)), max_tie_programs=8)
    assert r.status == "optimal" and r.cost == library.costs[14] and len(r.suite) == 1 and r.suite[0] in trio
    assert sorted(t[0] for t in r.ties) == sorted(trio - set(r.suite)) and all(len(t) == 1 for t in r.ties)
    assert r.ties_exhaustive
    r0 = cheapest_suite(fs, lambda s: bool(trio & set(s)), max_tie_programs=0)
    assert r0.cost == r.cost and not r0.ties_exhaustive


def _invoke(args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.mark.parametrize("text", ["100%", "-5", "ten", "nan"])
def test_bad_margin_one_line_exit_2(text):
    r = _invoke(["require", "--fixture", "tiny", "-q", "--preset", "freeway", "--margin", text])
    assert r.exit_code == 2
    err = [line for line in r.stderr.splitlines() if line.startswith("sensorsel: error:")]
    assert len(err) == 1 and "--margin" in err[0], r.output


def test_route_without_landmark_file_is_refused(tmp_path):
    """A route given as a pose file with no landmark map: one line naming the ways out, exit 2;
    with --landmarks synthetic it runs and the suite's line says the landmarks are invented."""
    poses = tmp_path / "drive.txt"
    src = np.loadtxt("data/kitti_fixtures/poses/tiny.txt")
    np.savetxt(poses, src)
    r = _invoke(["require", "--route", poses, "--route-format", "kitti", "-q", "--preset", "freeway"])
    assert r.exit_code == 2
    err = [line for line in r.stderr.splitlines() if line.startswith("sensorsel: error:")]
    assert len(err) == 1 and "--landmarks synthetic" in err[0] and "no landmark file" in err[0], r.output
    ok = _invoke(
        [
            "require",
            "--route",
            poses,
            "--route-format",
            "kitti",
            "-q",
            "--preset",
            "freeway",
            "--landmarks",
            "synthetic",
            "--max-sensors",
            "3",
        ]
    )
    assert ok.exit_code in (0, 2), ok.output
    if ok.exit_code == 0:
        suite_line = [line for line in ok.stdout.splitlines() if line.startswith("suite")][0]
        assert "INVENTED landmarks" in suite_line
