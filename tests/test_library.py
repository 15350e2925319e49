"""The sensor library: Table I in the default file, its expansion to 62 placed sensors, the noise
models, and validation of a user's library file (one clear error naming file and key, exit code 2)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.errors import InputError, LibraryError
from sensorsel.io.resources import default_library_path
from sensorsel.model.library import load_library, parse_library

REPO = Path(__file__).resolve().parents[1]

# Table I of Collin & Teran Espinoza (arXiv 1907.08541), copied by hand from the paper's table:
# code -> (range m, FOV rad, sigma_range m, sigma_bearing rad, cost $) for LiDARs and radars,
#         (range m, FOV rad, baseline m, focal px, cost $) for stereo cameras.
TABLE_I_RANGING = {
    "LRL": (120, 2 * math.pi, 0.084, 0.00110, 100_000),
    "MRR": (160, 0.1, 0.04, 0.00175, 2_830),
    "LRR": (250, 0.0698, 0.013, 0.00175, 1_493),
    "MRL": (100, 2 * math.pi, 0.03, 0.00524, 4_000),
}
TABLE_I_STEREO = {
    "WSC": (50, math.pi / 2, 0.5371, 721.5377, 2_990),
    "HD2K": (20, 1.33, 0.120, 1400, 449),
    "LSC": (20, 1.52, 0.120, 350, 449),
}
# The paper's row names of the same models, to find them in its LaTeX.
PAPER_ROW_NAMES = {
    "LRL": "Long Range LiDAR",
    "MRR": "Mid-Range Radar",
    "LRR": "Long-range Radar",
    "MRL": "Mid-Range LiDAR",
    "WSC": "Wide angle stereo camera",
    "HD2K": "HD2K stereo camera",
    "LSC": "Low resolution stereo camera",
}


def _models(lib):
    return {s.model.code: s.model for s in lib}


# ----------------------------------------------------------------------------- the default library


def test_default_library_expands_to_62_unique_sensors(library):
    assert len(library) == 62
    assert len(set(library.ids)) == 62
    assert len({s.index for s in library}) == 62
    by_type = {}
    for s in library:
        by_type.setdefault(s.model.type, []).append(s)
    # 2 roof LiDARs + (2 radars + 3 stereo cameras) x 12 clock positions
    assert len(by_type["lidar"]) == 2 and all(s.clock is None for s in by_type["lidar"])
    assert len(by_type["radar"]) == 24 and len(by_type["stereo"]) == 36
    for code in ("MRR", "LRR", "WSC", "HD2K", "LSC"):
        assert sorted(s.clock for s in library if s.model.code == code) == list(range(1, 13))


def test_ids_indices_and_facings_follow_the_documented_scheme(library):
    # as documented in configs/sensor_library.yaml: digit + clock counted 0..11 from 12 o'clock
    assert library[library.position("LRR-12")].index == 30
    assert library[library.position("MRR-6")].index == 26
    assert library[library.position("LRR-11")].index == 311
    assert library[library.position("LRL-roof")].index == 1
    assert library.position("30") == library.position("LRR-12")
    for clock, angle in ((12, 0.0), (3, -math.pi / 2), (6, -math.pi), (9, -3 * math.pi / 2), (1, -math.pi / 6)):
        s = library[library.position(f"HD2K-{clock}")]
        # same direction (angles compared on the circle)
        assert math.isclose(math.cos(s.mount_angle_rad), math.cos(angle), abs_tol=1e-12)
        assert math.isclose(math.sin(s.mount_angle_rad), math.sin(angle), abs_tol=1e-12)
    with pytest.raises(InputError, match="NOPE-3"):
        library.position("NOPE-3")


def test_table_i_numbers_are_in_the_default_file(library):
    models = _models(library)
    assert set(models) == set(TABLE_I_RANGING) | set(TABLE_I_STEREO)
    for code, (rng, fov, s_r, s_b, cost) in TABLE_I_RANGING.items():
        m = models[code]
        assert (m.range_m, m.sigma_range_m, m.sigma_bearing_rad, m.cost_usd) == (rng, s_r, s_b, cost), code
        assert math.isclose(m.fov_rad, fov, rel_tol=1e-12), code
    for code, (rng, fov, base, focal, cost) in TABLE_I_STEREO.items():
        m = models[code]
        assert m.type == "stereo"
        assert (m.range_m, m.baseline_m, m.focal_px, m.cost_usd) == (rng, base, focal, cost), code
        assert math.isclose(m.fov_rad, fov, rel_tol=1e-12), code
    lib_costs = library.costs
    assert lib_costs.shape == (62,)
    assert library.cost(library.parse_suite("LRL-roof,LRR-12,HD2K-3")) == 100_000 + 1_493 + 449


def _paper_table_rows(paper_dir: Path) -> dict[str, list[str]]:
    """The rows of the paper's Table I, from its LaTeX ($SENSORSEL_PAPER_DIR, tests/conftest.py)."""
    tex = sorted(paper_dir.glob("*.txt"))[0].read_text(encoding="utf-8")
    body = tex[tex.index(r"\label{StereoTable}") - 4000 : tex.index(r"\label{StereoTable}")]
    body = body[body.index(r"\begin{tabular}") : body.index(r"\end{tabular}")]
    rows = {}
    for line in body.splitlines():
        cells = [c.strip() for c in line.split("&")]
        if len(cells) >= 6:
            rows[cells[0].replace(r"$\star$", "").strip()] = cells[1:6]
    return rows


def _paper_number(cell: str) -> float:
    cell = cell.replace("$", "").replace(",", "").strip()
    if cell == r"2\pi":
        return 2 * math.pi
    if cell == r"\pi/2":
        return math.pi / 2
    return float(cell)


def test_hand_copied_table_matches_the_paper_text(paper_dir):
    """The oracle above is checked against the paper's LaTeX table itself."""
    rows = _paper_table_rows(paper_dir)
    for code, name in PAPER_ROW_NAMES.items():
        values = [_paper_number(c) for c in rows[name]]
        expected = TABLE_I_RANGING.get(code) or TABLE_I_STEREO[code]
        assert np.allclose(values, expected, rtol=1e-12), (code, values, expected)


# --------------------------------------------------------------------------------- noise models


@pytest.mark.parametrize("code", ["WSC", "HD2K", "LSC"])
def test_stereo_range_sigma_grows_as_z_squared(library, code):
    m = _models(library)[code]
    _, _, base, focal, _ = TABLE_I_STEREO[code]
    z = np.array([1.0, 2.5, 7.0, 19.0])
    s1, s2 = m.range_sigma(z), m.range_sigma(2 * z)
    assert s1.shape == z.shape
    np.testing.assert_allclose(s2 / s1, 4.0, rtol=1e-12)
    # the paper's eq. 5 with the sigma_d documented in the file (0.5 px)
    assert m.sigma_disparity_px == 0.5
    np.testing.assert_allclose(s1, z**2 / (focal * base) * 0.5, rtol=1e-12)


@pytest.mark.parametrize("code", ["WSC", "HD2K", "LSC"])
def test_camera_bearing_sigma_is_pixel_sigma_over_focal(library, code):
    m = _models(library)[code]
    assert m.sigma_pixel_px == 1.0
    assert math.isclose(m.bearing_sigma(), 1.0 / TABLE_I_STEREO[code][3], rel_tol=1e-12)


@pytest.mark.parametrize("code", sorted(TABLE_I_RANGING))
def test_ranging_sensor_noise_is_the_tables(library, code):
    m = _models(library)[code]
    np.testing.assert_array_equal(m.range_sigma(np.array([1.0, 50.0, 200.0])), TABLE_I_RANGING[code][2])
    assert m.bearing_sigma() == TABLE_I_RANGING[code][3]


def test_subset_keeps_order_and_sensors(library):
    pos = [library.position("LRR-3"), library.position("LRL-roof")]
    sub = library.subset(pos)
    assert sub.ids == ("LRR-3", "LRL-roof")
    assert sub[0] is library[pos[0]]


# ------------------------------------------------------------------------------ bad library files


def _default_doc() -> dict:
    return yaml.safe_load(default_library_path().read_text(encoding="utf-8"))


def _set(i: int, **fields):
    def mutate(doc):
        doc["models"][i].update(fields)

    return mutate


def _drop(i: int, key: str):
    def mutate(doc):
        del doc["models"][i][key]

    return mutate


# (case id, mutation of the parsed default file, key path the message must name, fragment of the message)
BAD_DOCS = [
    ("unknown-key", _set(1, beam_width=3), "models[1].beam_width", "unknown key"),
    ("unknown-top-key", lambda d: d.update(sensors=[]), "sensors", "unknown top-level key"),
    ("missing-field", _drop(1, "range_m"), "models[1].range_m", "missing required field"),
    ("missing-stereo-field", _drop(4, "focal_px"), "models[4].focal_px", "missing required field"),
    ("missing-type", _drop(2, "type"), "models[2].type", "missing required field"),
    ("unknown-type", _set(1, type="sonar"), "models[1].type", "unknown sensor type 'sonar'"),
    ("zero-range", _set(1, range_m=0), "models[1].range_m", "must be positive"),
    ("negative-range", _set(2, range_m=-250), "models[2].range_m", "must be positive"),
    ("zero-sigma-range", _set(0, sigma_range_m=0), "models[0].sigma_range_m", "must be positive"),
    ("negative-sigma-bearing", _set(3, sigma_bearing_rad=-0.001), "models[3].sigma_bearing_rad", "must be positive"),
    ("negative-disparity-noise", _set(5, sigma_disparity_px=-0.5), "models[5].sigma_disparity_px", "must be positive"),
    ("zero-pixel-noise", _set(6, sigma_pixel_px=0), "models[6].sigma_pixel_px", "must be positive"),
    ("zero-cost", _set(2, cost_usd=0), "models[2].cost_usd", "must be positive"),
    ("zero-focal", _set(4, focal_px=0), "models[4].focal_px", "must be positive"),
    ("negative-baseline", _set(5, baseline_m=-0.12), "models[5].baseline_m", "must be positive"),
    ("fov-zero", _set(1, fov_rad=0), "models[1].fov_rad", "(0, 2*pi]"),
    ("fov-negative", _set(1, fov_rad=-0.1), "models[1].fov_rad", "(0, 2*pi]"),
    ("fov-above-2pi", _set(0, fov_rad=6.3), "models[0].fov_rad", "(0, 2*pi]"),
    ("nan-range", _set(1, range_m=float("nan")), "models[1].range_m", "finite"),
    ("duplicate-code", _set(2, code="MRR"), "models[2].code", "duplicate code 'MRR'"),
    ("duplicate-digit", _set(4, digit=3), "models[4].digit", "duplicate digit 3"),
    ("colliding-index", _set(1, digit=0), "models[1].digit", "collides with LRL-roof"),
    ("string-range", _set(1, range_m="far"), "models[1].range_m", "expected a number, got 'far'"),
    ("quoted-number", _set(2, cost_usd="1493"), "models[2].cost_usd", "expected a number, got '1493'"),
    ("bool-number", _set(1, sigma_range_m=True), "models[1].sigma_range_m", "expected a number"),
    ("list-number", _set(4, baseline_m=[0.5]), "models[4].baseline_m", "expected a number"),
    ("string-digit", _set(1, digit="2"), "models[1].digit", "expected an integer 0..9"),
    ("number-code", _set(1, code=42), "models[1].code", "expected a non-empty string"),
    ("bad-mount", _set(1, mount="bumper"), "models[1].mount", "bumper"),
    ("bad-clock", lambda d: d.update(clock_positions=[12, 13]), "clock_positions[1]", "1..12"),
    ("repeated-clock", lambda d: d.update(clock_positions=[12, 3, 3]), "clock_positions", "repeats"),
    ("model-not-mapping", lambda d: d["models"].__setitem__(3, "LRR"), "models[3]", "expected a mapping"),
    ("no-models", lambda d: d.update(models=[]), "models", "non-empty list"),
]


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("case,mutate,key,fragment", BAD_DOCS, ids=[c[0] for c in BAD_DOCS])
def test_bad_library_raises_library_error_naming_file_and_key(tmp_path, case, mutate, key, fragment):
    doc = _default_doc()
    mutate(doc)
    path = _write(tmp_path, f"{case}.yaml", yaml.safe_dump(doc, sort_keys=False))
    with pytest.raises(LibraryError) as err:
        load_library(path)
    assert err.value.key == key
    msg = str(err.value)
    assert str(path) in msg and f": {key}: " in msg and fragment in msg, msg


def _cli_fails(args: list[str], *fragments: str) -> str:
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 2, result.output
    assert isinstance(result.exception, SystemExit)  # a handled error, not a crash
    assert "Traceback" not in result.output
    err = result.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("sensorsel: error: ")
    for f in fragments:
        assert f in err, (f, err)
    return err


@pytest.mark.parametrize("command", ["library", "score"])
@pytest.mark.parametrize("case,mutate,key,fragment", BAD_DOCS, ids=[c[0] for c in BAD_DOCS])
def test_bad_library_exits_2_from_cli(tmp_path, command, case, mutate, key, fragment):
    doc = _default_doc()
    mutate(doc)
    path = _write(tmp_path, f"{case}.yaml", yaml.safe_dump(doc, sort_keys=False))
    extra = ["--suite", "LRL-roof", "--fixture", "tiny"] if command == "score" else []
    _cli_fails([command, "--library", str(path), *extra], str(path), key, fragment)


def _default_lines() -> list[str]:
    return default_library_path().read_text(encoding="utf-8").splitlines()


def _line_of(lines: list[str], text: str) -> int:
    return next(i for i, line in enumerate(lines) if line.strip() == text)


def test_malformed_yaml_names_the_line(tmp_path):
    lines = _default_lines()
    i = _line_of(lines, "range_m: 160")
    lines[i] = lines[i] + ": 3"  # "range_m: 160: 3" is not YAML
    path = _write(tmp_path, "malformed.yaml", "\n".join(lines) + "\n")
    with pytest.raises(LibraryError, match=rf"malformed YAML: line {i + 1}\b"):
        load_library(path)
    for command in (["library"], ["score", "--suite", "LRL-roof"]):
        _cli_fails([*command, "--library", str(path)], str(path), f"line {i + 1}")


def test_unclosed_bracket_and_tab_name_a_line(tmp_path):
    path = _write(tmp_path, "tab.yaml", "clock_positions: [12, 3]\nmodels:\n\t- code: X\n")
    _cli_fails(["library", "--library", str(path)], str(path), "line 3", "malformed YAML")
    path = _write(tmp_path, "bracket.yaml", "clock_positions: [12, 3\nmodels: []\n")
    err = _cli_fails(["library", "--library", str(path)], str(path), "malformed YAML")
    assert re.search(r"line \d+", err)


def test_control_character_is_one_line_with_its_line(tmp_path):
    path = _write(tmp_path, "ctrl.yaml", "clock_positions: [12]\nmodels: \x07\n")
    _cli_fails(["library", "--library", str(path)], str(path), "line 2", "#x0007")


def test_repeated_key_is_refused_with_both_lines(tmp_path):
    lines = _default_lines()
    i = _line_of(lines, "range_m: 160")
    lines.insert(i + 1, lines[i].replace("160", "170"))
    path = _write(tmp_path, "repeated.yaml", "\n".join(lines) + "\n")
    _cli_fails(["library", "--library", str(path)], str(path), "'range_m' repeated", f"line {i + 2}", f"line {i + 1})")


def test_scientific_notation_is_a_number(tmp_path):
    """1e5 and 1.1e-3 are numbers (YAML 1.2), although PyYAML's YAML 1.1 would read them as text."""
    text = default_library_path().read_text(encoding="utf-8")
    text = text.replace("cost_usd: 100000", "cost_usd: 1e5").replace(
        "sigma_bearing_rad: 0.00110", "sigma_bearing_rad: 1.1e-3"
    )
    lib = load_library(_write(tmp_path, "exp.yaml", text))
    assert lib.costs[lib.position("LRL-roof")] == 100_000
    assert lib[lib.position("LRL-roof")].model.sigma_bearing_rad == 0.0011


def test_quoted_number_gets_a_hint(tmp_path):
    text = default_library_path().read_text(encoding="utf-8").replace("cost_usd: 100000", 'cost_usd: "100000"')
    path = _write(tmp_path, "quoted.yaml", text)
    _cli_fails(["library", "--library", str(path)], str(path), "models[0].cost_usd", "remove the quotes")


@pytest.mark.parametrize("text,fragment", [("", "expected a mapping"), ("- 1\n- 2\n", "got list"), ("42\n", "got int")])
def test_empty_or_non_mapping_document(tmp_path, text, fragment):
    path = _write(tmp_path, "doc.yaml", text)
    _cli_fails(["library", "--library", str(path)], str(path), fragment)


def test_missing_library_file(tmp_path):
    path = tmp_path / "nowhere.yaml"
    _cli_fails(["library", "--library", str(path)], str(path), "not found")
    _cli_fails(["score", "--suite", "LRL-roof", "--library", str(path)], str(path), "not found")


def test_users_copy_with_a_new_model_is_accepted(tmp_path):
    """Adding a model by editing a copy: the expansion follows the file."""
    doc = _default_doc()
    doc["models"].append(
        dict(
            code="SRR",
            name="Short-range radar",
            type="radar",
            digit=8,
            mount="clock",
            range_m=30,
            fov_rad=1.2,
            sigma_range_m=0.1,
            sigma_bearing_rad=0.01,
            cost_usd=150,
        )
    )
    doc["clock_positions"] = [12, 3, 6, 9]
    lib = parse_library(doc, "copy.yaml")
    assert len(lib) == 2 + 6 * 4
    assert lib[lib.position("SRR-9")].index == 89
    assert lib.source == "copy.yaml"
