"""Operating-domain files: the shipped examples load, and every bad file fails naming the
file, the key path and the line."""

from __future__ import annotations

from pathlib import Path

import pytest

from sensorsel.io.resources import fixtures_dir
from sensorsel.model.domain import DomainError, load_domain_file, load_domain_scenarios
from sensorsel.model.scenario import KITTI_ROOT_ENV, load_scenario

REPO = Path(__file__).resolve().parents[1]
FIX = fixtures_dir()


def _domain(tmp_path: Path, text: str) -> Path:
    (tmp_path / "maps").mkdir(exist_ok=True)
    (tmp_path / "maps" / "a.csv").write_text("x,y\n10,20\n30,-40\n")
    path = tmp_path / "domain.yaml"
    path.write_text(text)
    return path


GOOD = f"""\
keyframe_rate_hz: 1.0
routes:
  - name: suburb
    fixture: suburb
    weight: {{hours: 2}}
  - name: tiny-file
    route: {FIX / "poses" / "tiny.txt"}
    times: {FIX / "sequences" / "tiny" / "times.txt"}
    landmarks: maps/a.csv
    weight: 0.5
  - name: tiny-syn
    fixture: tiny
    landmarks: {{synthetic: {{seed: 3}}}}
"""


def test_fixture_domain_loads_with_weights_and_relative_paths(tmp_path):
    d = load_domain_file(_domain(tmp_path, GOOD))
    assert d.names == ("suburb", "tiny-file", "tiny-syn") and d.weight_unit == "hours"
    assert d.routes[1].spec.landmarks == str(tmp_path / "maps" / "a.csv")
    loaded = load_domain_scenarios(d)
    assert [s.weight for s in loaded[:2]] == [2.0, 0.5]
    tiny = loaded[2].scenario
    assert loaded[2].weight == pytest.approx(tiny.route.duration_s / 3600.0)
    assert tiny.landmark_source == "generated (seed 3)" and tiny.name == "tiny-syn"
    assert loaded[1].scenario.n_landmarks == 2
    # the spec is the scenario's provenance: loading it again gives the same scenario
    again = load_scenario(loaded[1].spec)
    assert (again.name, again.n_poses, again.n_landmarks) == ("tiny-file", loaded[1].scenario.n_poses, 2)


def test_shipped_fixture_domain():
    loaded = load_domain_scenarios(load_domain_file(REPO / "configs" / "domain_fixtures.yaml"))
    assert [s.name for s in loaded] == ["suburb", "tiny"] and loaded[0].weight == 2.0
    assert loaded[1].scenario.landmark_source == "generated (seed 3)"


@pytest.mark.kitti
def test_shipped_kitti_domain_weighs_km_driven(kitti_root, monkeypatch):
    monkeypatch.setenv(KITTI_ROOT_ENV, str(kitti_root))
    d = load_domain_file(REPO / "configs" / "domain_kitti.yaml")
    assert [r.spec.seq for r in d.routes] == ["00", "02", "03", "04", "06", "08", "10"] and d.weight_unit == "km"
    for s in load_domain_scenarios(d):
        assert (
            s.scenario.landmark_source == f"KITTI pole map {kitti_root.resolve() / 'landmarks' / (s.spec.seq + '.csv')}"
        )
        assert s.weight == pytest.approx(s.scenario.route.length_m / 1000.0) and s.unit == "km"
    # the README's lengths (km)
    assert [round(s.weight, 2) for s in load_domain_scenarios(d)] == [3.72, 5.06, 0.56, 0.39, 1.23, 3.21, 0.92]


def _line_of(text: str, fragment: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), start=1) if fragment in line)


def _fails(tmp_path, text: str, key: str, line_fragment: str | None, message: str):
    path = _domain(tmp_path, text)
    with pytest.raises(DomainError) as err:
        load_domain_file(path)
    e = err.value
    assert e.path == str(path) and str(path) in str(e), str(e)
    assert e.key == key, str(e)
    if line_fragment is not None:
        assert e.line == _line_of(text, line_fragment), str(e)
        assert f"{path}:{e.line}:" in str(e)
    assert message in str(e), str(e)
    return str(e)


@pytest.mark.parametrize(
    "old,new,key,line_fragment,message",
    [
        ("keyframe_rate_hz: 1.0", "keyframe_rate: 1.0", "keyframe_rate", "keyframe_rate:", "unknown key"),
        ("    weight: 0.5", "    wieght: 0.5", "routes[1].wieght", "wieght", "unknown key"),
        ("    weight: 0.5", "    weight: half", "routes[1].weight", "weight: half", "expected a number"),
        ("    weight: 0.5", "    weight: '0.5'", "routes[1].weight", "weight: '0.5'", "remove the quotes"),
        ("    weight: 0.5", "    weight: -1", "routes[1].weight", "weight: -1", "> 0"),
        ("    weight: 0.5", "    weight: {km: 3}", "routes[1].weight.km", "weight: {km: 3}", "weight_unit: hours"),
        ("    weight: 0.5", "    weight: {miles: 3}", "routes[1].weight", "weight: {miles", "expected {km: X}"),
        (
            "keyframe_rate_hz: 1.0",
            "keyframe_rate_hz: fast",
            "keyframe_rate_hz",
            "keyframe_rate_hz",
            "expected a number",
        ),
        ("keyframe_rate_hz: 1.0", "weight_unit: miles", "weight_unit", "weight_unit", "hours, km"),
        ("  - name: tiny-syn", "  - name: suburb", "routes[2].name", "- name: suburb\n", "duplicate name 'suburb'"),
        ("  - name: tiny-syn", "  - name: 3", "routes[2].name", "- name: 3", "expected a non-empty line of text"),
        (
            "    landmarks: maps/a.csv",
            "    landmarks: maps/b.csv",
            "routes[1].landmarks",
            "maps/b.csv",
            "file not found",
        ),
        ("    landmarks: maps/a.csv", "    landmarks: 7", "routes[1].landmarks", "landmarks: 7", "a landmark CSV file"),
        ("    landmarks: maps/a.csv", "    landmarks: real", "routes[1].landmarks", "landmarks: real", "pole map"),
        (
            "    landmarks: {synthetic: {seed: 3}}",
            "    landmarks: {synthetic: {sead: 3}}",
            "routes[2].landmarks.synthetic.sead",
            "sead",
            "unknown key",
        ),
        (
            "    landmarks: {synthetic: {seed: 3}}",
            "    landmarks: {synthetic: {seed: -3}}",
            "routes[2].landmarks.synthetic.seed",
            "seed: -3",
            "integer >= 0",
        ),
        ("    fixture: tiny", "    fixture: huge", "routes[2].fixture", "fixture: huge", "unknown fixture"),
        (
            "    fixture: tiny",
            "    fixture: tiny\n    route: x.txt",
            "routes[2]",
            "route: x.txt",
            "exactly one of seq, route, fixture",
        ),
        ("    fixture: tiny", "    landmarks2: x", "routes[2].landmarks2", "landmarks2", "unknown key"),
        (
            "    fixture: suburb",
            "    fixture: suburb\n    format: tum",
            "routes[0].format",
            "format: tum",
            "goes with route",
        ),
    ],
)
def test_bad_domain_files_name_file_key_and_line(tmp_path, old, new, key, line_fragment, message):
    assert old in GOOD
    text = GOOD.replace(old, new, 1)
    if line_fragment.endswith("\n"):  # the second occurrence (a duplicate)
        lines = text.splitlines()
        idx = [i for i, line in enumerate(lines, start=1) if line_fragment.strip() in line][1]
        path = _domain(tmp_path, text)
        with pytest.raises(DomainError) as err:
            load_domain_file(path)
        assert (err.value.key, err.value.line) == (key, idx) and message in str(err.value), str(err.value)
        assert "also routes[0], line 3" in str(err.value)
        return
    _fails(tmp_path, text, key, line_fragment, message)


def test_missing_route_and_times_files(tmp_path):
    text = GOOD.replace(str(FIX / "poses" / "tiny.txt"), "drives/none.txt")
    _fails(tmp_path, text, "routes[1].route", "drives/none.txt", f"file not found: {tmp_path / 'drives' / 'none.txt'}")
    text = GOOD.replace(str(FIX / "sequences" / "tiny" / "times.txt"), "nope/times.txt")
    _fails(tmp_path, text, "routes[1].times", "nope/times.txt", "file not found")
    _fails(
        tmp_path, GOOD.replace("keyframe_rate_hz: 1.0", "library: lib.yaml"), "library", "library:", "file not found"
    )


def test_sequence_routes(tmp_path, monkeypatch):
    monkeypatch.delenv(KITTI_ROOT_ENV, raising=False)
    text = "routes:\n  - name: a\n    seq: 3\n"
    _fails(tmp_path, text, "routes[0].seq", "seq: 3", 'in quotes: "03"')
    text = 'routes:\n  - name: a\n    seq: "03"\n'
    _fails(tmp_path, text, "routes[0].seq", "seq:", "no KITTI folder")
    (tmp_path / "kitti" / "poses").mkdir(parents=True)
    text = 'kitti_root: kitti\nroutes:\n  - name: a\n    seq: "03"\n'
    _fails(tmp_path, text, "routes[0].seq", "seq:", "not found")
    text = 'kitti_root: nowhere\nroutes:\n  - name: a\n    seq: "03"\n'
    _fails(tmp_path, text, "kitti_root", "kitti_root", "folder not found")
    text = "routes:\n  - name: a\n    fixture: tiny\n    kitti_root: kitti\n"
    _fails(tmp_path, text, "routes[0].kitti_root", "kitti_root", "goes with seq")


@pytest.mark.kitti
def test_sequence_route_with_real_map_default(tmp_path, kitti_root):
    text = f'kitti_root: {kitti_root}\nclearance_m: 3\nroutes:\n  - name: city\n    seq: "03"\n    weight: 1.5\n'
    (s,) = load_domain_scenarios(load_domain_file(_domain(tmp_path, text)))
    assert s.scenario.landmark_source.startswith("KITTI pole map") and s.weight == 1.5
    assert s.scenario.landmark_report.clearance_m == 3.0 and s.scenario.name == "city"


@pytest.mark.parametrize(
    "text,key,line,message",
    [
        ("", "", None, "expected a mapping"),
        ("routes: []\n", "routes", 1, "non-empty list"),
        ("keyframe_rate_hz: 1\n", "routes", 1, "missing"),
        ("routes:\n  - fixture: tiny\n", "routes[0].name", 2, "missing"),
        ("routes:\n  - tiny\n", "routes[0]", 2, "expected a mapping"),
        ("routes:\n  - name: a\n    fixture: tiny\n    fixture: suburb\n", "", 4, "repeated"),
        ("routes:\n  - name: a\n   fixture: [\n", "", None, "malformed YAML"),
        ("routes: !!python/object:os.system {}\n", "", 1, "malformed YAML"),
    ],
)
def test_structurally_bad_domain_files(tmp_path, text, key, line, message):
    path = _domain(tmp_path, text)
    with pytest.raises(DomainError) as err:
        load_domain_file(path)
    assert err.value.key == key and message in str(err.value) and str(path) in str(err.value), str(err.value)
    if line is not None:
        assert err.value.line == line, str(err.value)


def test_missing_domain_file(tmp_path):
    with pytest.raises(DomainError, match="not found"):
        load_domain_file(tmp_path / "none.yaml")
