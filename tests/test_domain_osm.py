"""A domain file names GPS tracks and OpenStreetMap landmarks itself (``route: TRACK.gpx``,
``osm``, ``osm_classes``, ``osm_reach_m``, ``georef``), so that a city nobody has driven yet is an
operating domain with conditions like any other.

Oracle: each route of such a domain is the problem the route commands build from the same inputs
(``load_problem`` of the ``--route``/``--landmarks osm:``/``--georef`` spec, itself tested against
the CLI and a georeferenced CSV in test_osm_routes.py): same landmarks, same scores to the bit.
Bad input: one line naming the file, the line and the key, exit 2, nothing written.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from test_osm_routes import GEOREF, SAMPLE, _drive

from sensorsel.cli import cli
from sensorsel.information.evaluators import make_evaluator
from sensorsel.model.domain import DomainError, load_domain_file
from sensorsel.model.problem import load_domain, load_problem
from sensorsel.model.scenario import ScenarioSpec

SUITES = (("LRL-roof",), ("MRL-roof", "LRR-5", "HD2K-8"))


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    return _drive(tmp_path_factory.mktemp("drive"))


def _domain(folder: Path, body: str) -> Path:
    path = folder / "city.yaml"
    path.write_text(body)
    return path


def test_gpx_and_georeferenced_routes_with_osm_landmarks_are_the_route_commands_problems(drive, tmp_path):
    csv, gpx, _ = drive
    path = _domain(
        tmp_path,
        f"weight_unit: km\nroutes:\n"
        f"  - {{name: track, route: {gpx}, osm: {SAMPLE}}}\n"
        f"  - {{name: survey, route: {csv}, georef: '{GEOREF}', osm: [{SAMPLE}], osm_classes: [street_lamp, tree],"
        f" osm_reach_m: 60}}\n",
    )
    dom = load_domain(path)
    alone = [
        load_problem(ScenarioSpec(route=str(gpx), osm=(str(SAMPLE),))),
        load_problem(
            ScenarioSpec(
                route=str(csv), georef=GEOREF, osm=(str(SAMPLE),), osm_classes="street_lamp,tree", osm_reach_m=60.0
            )
        ),
    ]
    assert [r.name for r in dom.routes] == ["track", "survey"]
    for member, problem in zip(dom.routes, alone):
        np.testing.assert_array_equal(member.problem.scenario.landmarks, problem.scenario.landmarks)
        assert member.problem.fingerprint == problem.fingerprint
        mine, theirs = make_evaluator(member.problem), make_evaluator(problem)
        lib = member.problem.library
        for suite in SUITES:
            pos = [lib.position(s) for s in suite]
            assert mine.score(pos) == theirs.score(pos)
        # weighted by length (km): the 294 m drive, both ways
        assert member.weight == pytest.approx(problem.scenario.keyframes.length_m / 1000.0, rel=0.02)
    # the choice of classes and reach is the survey route's own: fewer landmarks than all classes at 100 m
    assert dom.routes[1].problem.scenario.n_landmarks < dom.routes[0].problem.scenario.n_landmarks


def test_a_gpx_domain_in_conditions_runs_greedy_from_the_cli(drive, tmp_path):
    _, gpx, _ = drive
    path = _domain(
        tmp_path,
        "conditions:\n  - {name: night, night: true, share: 0.3}\n"
        f"routes:\n  - {{name: track, route: {gpx}, osm: {SAMPLE}}}\n",
    )
    dom = load_domain(path)
    assert [r.name for r in dom.routes] == ["track/clear", "track/night"]
    out = tmp_path / "greedy.json"
    r = CliRunner().invoke(cli, ["greedy", "--domain", str(path), "--budget", "20000", "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert out.is_file() and "track/night" in out.read_text()


@pytest.mark.parametrize(
    "route, extra, key, words",
    [
        ("csv", "osm: {osm}", "routes[0].osm", ("not georeferenced", "georef")),
        ("gpx", "osm: {osm}, georef: '60,24,0'", "routes[0].georef", ("GPX", "drop georef")),
        ("csv", "georef: '{georef}'", "routes[0].georef", ("osm",)),
        ("gpx", "osm_reach_m: 50", "routes[0].osm_reach_m", ("osm",)),
        ("gpx", "osm: {osm}, osm_classes: lamppost", "routes[0].osm_classes", ("lamppost", "known")),
        ("gpx", "osm: {osm}, osm_reach_m: -5", "routes[0].osm_reach_m", ("> 0",)),
        ("gpx", "osm: missing.pbf", "routes[0].osm", ("not found",)),
        ("gpx", "osm: []", "routes[0].osm", ("empty",)),
        ("gpx", "osm: {osm}, landmarks: synthetic", "routes[0].landmarks", ("synthetic",)),
        ("gpx", "format: csv", "routes[0].format", ("GPX",)),
        ("csv", "osm: {osm}, georef: 'north'", "routes[0].georef", ("LAT,LON,BEARING",)),
    ],
)
def test_bad_osm_keys_name_the_key_and_its_line(drive, tmp_path, route, extra, key, words):
    csv, gpx, _ = drive
    body = f"routes:\n  - name: a\n    route: {gpx if route == 'gpx' else csv}\n" + "".join(
        f"    {kv.strip()}\n" for kv in extra.format(osm=SAMPLE, georef=GEOREF).split(", ")
    )
    path = _domain(tmp_path, body)
    with pytest.raises(DomainError) as e:
        load_domain_file(path)
    msg = str(e.value)
    assert str(path) in msg and key in msg, msg
    assert e.value.line is not None and e.value.line >= 3, msg  # the key's own line, not the route's
    for w in words:
        assert w in msg, (w, msg)
    # through the CLI: one line, exit 2, nothing written
    out = tmp_path / "out.json"
    r = CliRunner().invoke(cli, ["greedy", "--domain", str(path), "--budget", "20000", "-o", str(out)])
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.stderr.splitlines() if ln.strip() and not ln.startswith("sensorsel: note:")]
    assert len(lines) == 1 and key in lines[0] and "Traceback" not in r.output and not out.exists(), r.stderr


def test_what_only_reading_the_files_finds_names_the_file_or_the_domains_route(drive, tmp_path):
    import re

    from sensorsel.errors import ScenarioError

    csv, gpx, _ = drive
    # a file that is no OSM extract: named by its own error
    path = _domain(tmp_path, f"routes:\n  - name: a\n    route: {gpx}\n    osm: {csv}\n")
    with pytest.raises(ScenarioError, match="not an OSM extract") as e:
        load_domain(path)
    assert str(csv) in str(e.value)
    # a track a degree north of the extract: the domain's route, named with its line
    far = tmp_path / "far.gpx"
    far.write_text(re.sub(r'lat="([^"]+)"', lambda m: f'lat="{float(m.group(1)) + 1.0!r}"', gpx.read_text()))
    path = _domain(
        tmp_path, f"routes:\n  - name: first\n    fixture: tiny\n  - name: far\n    route: {far}\n    osm: {SAMPLE}\n"
    )
    with pytest.raises(DomainError) as d:
        load_domain(path)
    msg = str(d.value)
    assert (
        str(path) in msg and "routes[1]" in msg and "far" in msg and "outside the extract" in msg and d.value.line == 4
    ), msg
    assert "--landmarks" not in msg and f"osm: {SAMPLE}" in msg, msg  # this file's words, not the CLI's
