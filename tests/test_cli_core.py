"""The first commands: ``sensorsel library``, ``score``, ``scene``."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.api import ScoreResult
from sensorsel.cli import cli
from sensorsel.information.evaluators import ReferenceEvaluator
from sensorsel.io import results
from sensorsel.model.scenario import ScenarioSpec

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


def ok(*args: str) -> str:
    result = invoke(*args)
    assert result.exit_code == 0, (result.output, result.exception)
    return result.stdout


def fails(*args: str) -> str:
    result = invoke(*args)
    assert result.exit_code == 2, result.output
    assert isinstance(result.exception, SystemExit) and "Traceback" not in result.output
    err = result.stderr.strip()
    assert len(err.splitlines()) == 1 and err.startswith("sensorsel: error: "), err
    return err


def _sensorsel_command() -> list[str]:
    script = Path(sys.executable).parent / "sensorsel"
    if script.is_file():
        return [str(script)]
    found = shutil.which("sensorsel")
    return [found] if found else [sys.executable, "-c", "from sensorsel.cli import main; main()"]


def test_library_lists_62_rows(library):
    out = ok("library").splitlines()
    header, rule = out[0].split(), out[1]
    assert header[:3] == ["id", "index", "model"] and "cost_usd" in header
    assert set(rule.replace(" ", "")) == {"-"}
    rows = out[2 : out.index("")]
    assert len(rows) == 62
    assert [r.split()[0] for r in rows] == list(library.ids)
    assert [int(r.split()[1]) for r in rows] == [s.index for s in library]
    lrr12 = next(r for r in rows if r.startswith("LRR-12 "))
    assert "12 o'clock" in lrr12 and "250" in lrr12 and "1,493" in lrr12
    assert out[out.index("") + 1].startswith("62 sensors from ")
    assert out[-2].startswith("resources  power_w [W]") and out[-1].startswith("slots      none")


def test_score_prints_cost_and_score(suburb_problem):
    out = ok("score", "--suite", "LRL-roof")
    assert re.search(r"^cost\s+\$100,000$", out, re.M), out
    m = re.search(r"^score\s+(-?\d+\.\d+) nats", out, re.M)
    assert m, out
    expect = ReferenceEvaluator(suburb_problem).score(suburb_problem.library.parse_suite("LRL-roof"))
    assert float(m.group(1)) == pytest.approx(expect, abs=5e-4)
    assert "suburb: 53 keyframes, 182 landmarks" in out


def test_score_accepts_paper_indices(tiny_problem):
    by_id = json.loads(ok("score", "--fixture", "tiny", "--suite", "LRR-12,MRR-6", "--json"))
    by_index = json.loads(ok("score", "--fixture", "tiny", "--suite", "30,26", "--json"))
    assert by_id == by_index
    assert by_id["suite"] == ["MRR-6", "LRR-12"] and by_id["cost_usd"] == 1493 + 2830


def test_score_json_round_trips(tmp_path):
    text = ok("score", "--fixture", "tiny", "--suite", "LRL-roof,WSC-12", "--json")
    data = json.loads(text)
    assert data["suite"] == ["LRL-roof", "WSC-12"] and data["cost_usd"] == 102_990
    path = tmp_path / "score.json"
    path.write_text(text)
    res = results.load(path, ScoreResult)
    assert isinstance(res, ScoreResult) and res.suite == ("LRL-roof", "WSC-12")
    assert res.score == data["score"] and res.problem.scenario == "tiny" and res.problem.n_sensors == 62
    assert results.dumps(res) == text  # same bytes back
    # deterministic: the same command prints the same bytes
    assert ok("score", "--fixture", "tiny", "--suite", "LRL-roof,WSC-12", "--json") == text


@pytest.mark.parametrize(
    "suite,fragment",
    [("LRL-roof,NOPE-3", "'NOPE-3'"), ("LRR-13", "'LRR-13'"), ("LRR-12,30", "names a sensor twice"), ("999", "'999'")],
)
def test_score_bad_suite(suite, fragment):
    assert fragment in fails("score", "--fixture", "tiny", "--suite", suite)


def test_scene_writes_a_png(tmp_path):
    out = tmp_path / "scene.png"
    assert str(out) in ok("scene", "--fixture", "tiny", "-o", str(out))
    assert out.read_bytes()[:8] == PNG_SIGNATURE
    cones = tmp_path / "cones.png"
    ok("scene", "--fixture", "tiny", "--suite", "LRL-roof,LRR-12,WSC-3", "--pose", "2", "-o", str(cones))
    assert cones.read_bytes()[:8] == PNG_SIGNATURE and cones.read_bytes() != out.read_bytes()


def test_scene_refuses_other_formats_and_bad_pose(tmp_path):
    out = tmp_path / "x.txt"
    err = fails("scene", "--fixture", "tiny", "-o", str(out))
    assert str(out) in err and ".txt" in err
    assert not out.exists() and list(tmp_path.iterdir()) == []
    assert "999" in fails(
        "scene", "--fixture", "tiny", "--suite", "LRL-roof", "--pose", "999", "-o", str(tmp_path / "y.png")
    )
    assert "'NOPE'" in fails("scene", "--fixture", "tiny", "--suite", "NOPE", "-o", str(tmp_path / "y.png"))


def test_commands_work_from_another_directory(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "SENSORSEL_KITTI_ROOT"}
    cmd = _sensorsel_command()
    lib = subprocess.run([*cmd, "library"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert lib.returncode == 0, lib.stderr
    assert "62 sensors from" in lib.stdout
    score = subprocess.run(
        [*cmd, "score", "--fixture", "tiny", "--suite", "LRL-roof", "--json"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert score.returncode == 0, score.stderr
    assert json.loads(score.stdout)["problem"]["scenario"] == "tiny"
    scene = subprocess.run(
        [*cmd, "scene", "-o", "s.png", "--fixture", "tiny"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert scene.returncode == 0, scene.stderr
    assert (tmp_path / "s.png").read_bytes()[:8] == PNG_SIGNATURE
    bad = subprocess.run(
        [*cmd, "score", "--suite", "NOPE"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120
    )
    assert bad.returncode == 2 and "NOPE" in bad.stderr and "Traceback" not in bad.stderr


@pytest.mark.kitti
def test_score_on_kitti_03(kitti_root):
    data = json.loads(ok("score", "--seq", "03", "--kitti-root", str(kitti_root), "--suite", "LRL-roof", "--json"))
    assert data["problem"]["scenario"] == "03" and 78 <= data["problem"]["n_poses"] <= 84
    assert data["score"] > 0 and data["n_measurements"] > 0


def _tiny_route_options() -> list[str]:
    from sensorsel.io.resources import fixtures_dir

    root = fixtures_dir()
    return ["--route", str(root / "poses" / "tiny.txt"), "--times", str(root / "sequences" / "tiny" / "times.txt")]


def test_landmarks_writes_the_generated_map_and_it_scores_the_same(tmp_path):
    from sensorsel.model.scenario import LandmarkModel, generate_landmarks, load_route, read_landmarks_csv

    route_opts = _tiny_route_options()
    out = tmp_path / "lm.csv"
    assert "landmarks to" in ok("landmarks", *route_opts, "--landmark-seed", "4", "-o", str(out))
    route, _, _ = load_route(ScenarioSpec(poses=route_opts[1], times=route_opts[3]))
    expect = generate_landmarks(route, LandmarkModel(), 4)
    assert read_landmarks_csv(out) == pytest.approx(expect, abs=1e-6)  # written with 6 decimals
    # the written map, passed back, scores as the map generated on the fly
    from_file = json.loads(ok("score", *route_opts, "--landmarks", str(out), "--suite", "LRR-12,WSC-3", "--json"))
    generated = json.loads(ok("score", *route_opts, "--landmark-seed", "4", "--suite", "LRR-12,WSC-3", "--json"))
    assert from_file["score"] == pytest.approx(generated["score"], rel=1e-6)
    assert from_file["n_measurements"] == generated["n_measurements"]


def test_landmarks_density_options_change_the_map(tmp_path):
    from sensorsel.model.scenario import read_landmarks_csv

    route_opts = _tiny_route_options()
    ok("landmarks", *route_opts, "--far-spacing", "1e6", "-o", str(tmp_path / "a.csv"))
    ok("landmarks", *route_opts, "--far-spacing", "1e6", "--near-spacing", "2.5", "-o", str(tmp_path / "b.csv"))
    a, b = read_landmarks_csv(tmp_path / "a.csv"), read_landmarks_csv(tmp_path / "b.csv")
    assert 1.6 * len(a) <= len(b) <= 2.4 * len(a)  # half the spacing: about twice the near landmarks
    ok("landmarks", *route_opts, "--near-offset", "20,30", "--far-spacing", "1e6", "-o", str(tmp_path / "c.csv"))
    c = read_landmarks_csv(tmp_path / "c.csv")
    from sensorsel.model.scenario import load_route

    route, _, _ = load_route(ScenarioSpec(poses=route_opts[1], times=route_opts[3]))
    dist = np.min(np.hypot(c[:, None, 0] - route.poses[None, :, 0], c[:, None, 1] - route.poses[None, :, 1]), axis=1)
    assert dist.min() >= 20 - 1.0 and dist.max() <= 30 + 1.0  # 10 Hz route: ~0.8 m between its points


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["--near-offset", "4"], "--near-offset '4': expected two distances"),
        (["--far-offset", "80,25"], "far_offset_m must be 0 <= low <= high"),
        (["--near-spacing", "0"], "near_spacing_m must be positive"),
        (["--clearance", "nan"], "clearance_m must be >= 0"),
    ],
)
def test_landmarks_bad_model_is_one_line(tmp_path, args, fragment):
    assert fragment in fails("landmarks", "--fixture", "tiny", *args, "-o", str(tmp_path / "x.csv"))
    assert not (tmp_path / "x.csv").exists()


def test_landmarks_refuses_an_input_map(tmp_path):
    result = invoke("landmarks", "--fixture", "tiny", "--landmarks", "a.csv", "-o", str(tmp_path / "x.csv"))
    assert result.exit_code == 2 and "this command writes one" in result.output


def test_a_domain_result_is_refused_as_a_suite_for_one_route(tmp_path):
    """A result computed on a domain names its suite for that domain: given to a command on one
    route, it is refused saying so (it was once read as a result that records no problem at all);
    with --force it is used, with the same words as a warning."""
    data = Path(__file__).resolve().parents[1] / "data" / "kitti_fixtures"
    route = f"route: {data / 'poses' / 'tiny.txt'}\n    format: kitti\n    times: {data / 'sequences/tiny/times.txt'}"
    (tmp_path / "d.yaml").write_text(
        "routes:\n"
        + "".join(
            f"  - name: {n}\n    {route}\n    landmarks: {{synthetic: {{seed: {s}}}}}\n"
            for n, s in (("a", 3), ("b", 4))
        )
    )
    lib = str(Path(__file__).resolve().parents[1] / "configs" / "reduced_library.yaml")
    out = str(tmp_path / "o.json")  # an optimum: a result kind that names a suite, here on a domain
    ok("optimal", "--domain", str(tmp_path / "d.yaml"), "--library", lib, "--budget", "5000", "-q", "-o", out)
    err = fails("score", "--fixture", "tiny", "--library", lib, "--suite", out)
    assert "it was computed on a domain, this run is on one route" in err and out in err
    forced = invoke("score", "--fixture", "tiny", "--library", lib, "--suite", out, "--force")
    assert forced.exit_code == 0 and "computed on a domain, this run is on one route" in forced.stderr
