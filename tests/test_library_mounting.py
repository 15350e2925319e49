"""Library resources, mounting slots and ``extends``: parsed as written, validated with
the file and key named, and drawn."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.errors import LibraryError
from sensorsel.model.library import SLOT_ANY, load_library, resource_unit

REPO = Path(__file__).resolve().parents[1]
CAR = REPO / "configs" / "car_one_radar_one_camera.yaml"


def _car(tmp_path: Path, slots: str, extra: str = "") -> Path:
    p = tmp_path / "car.yaml"
    p.write_text(f"extends: {REPO / 'configs' / 'sensor_library.yaml'}\n{extra}slots:\n{slots}")
    return p


def test_every_model_of_the_stock_library_declares_the_three_resources():
    lib = load_library()
    assert lib.resource_names == ("power_w", "mass_kg", "data_rate_mbps")
    for s in lib:
        assert [n for n, _ in s.model.resources] == ["power_w", "mass_kg", "data_rate_mbps"]
        assert all(v > 0 for _, v in s.model.resources)
    # the arrays follow the models: both LiDARs on the roof draw what their model line says
    power = lib.resource("power_w")
    assert power[lib.position("LRL-roof")] == 60.0 and power[lib.position("MRL-roof")] == 8.0
    assert [resource_unit(n) for n in lib.resource_names] == ["W", "kg", "Mbit/s"]


def test_the_car_file_changes_only_the_slots():
    stock, car = load_library(), load_library(CAR)
    assert stock.slots == () and car.sensors == stock.sensors
    # 12 clock positions x (radar, stereo) + the roof's lidar slot
    assert len(car.slots) == 25
    for sl in car.slots:
        members = [car[i] for i in sl.members]
        if sl.place == "roof":
            assert sl.kind == "lidar" and sl.capacity == 2 and {s.id for s in members} == {"LRL-roof", "MRL-roof"}
        else:
            assert sl.capacity == 1
            assert all(s.clock == int(sl.place) and s.model.type == sl.kind for s in members)
            # every sensor of that type at that position, by brute force over the library
            assert set(sl.members) == {
                i for i, s in enumerate(car) if s.clock == int(sl.place) and s.model.type == sl.kind
            }


def test_a_clock_number_replaces_the_clock_entry_kind_by_kind(tmp_path):
    lib = load_library(_car(tmp_path, "  clock: {radar: 1, stereo: 1}\n  '6': {radar: 2}\n  roof: {any: 1}\n"))
    by = {(sl.place, sl.kind): sl for sl in lib.slots}
    assert by[("6", "radar")].capacity == 2 and by[("6", "stereo")].capacity == 1
    assert by[("5", "radar")].capacity == 1
    assert by[("roof", SLOT_ANY)].members == tuple(i for i, s in enumerate(lib) if s.clock is None)


def test_subset_renumbers_slot_members():
    car = load_library(CAR)
    keep = [car.position(x) for x in ("HD2K-6", "LRR-6", "MRR-6", "LRL-roof")]
    sub = car.subset(keep)
    radar6 = next(sl for sl in sub.slots if sl.place == "6" and sl.kind == "radar")
    assert {sub[i].id for i in radar6.members} == {"LRR-6", "MRR-6"}
    assert all(max(sl.members) < len(sub) for sl in sub.slots)


@pytest.mark.parametrize(
    "slots, key, fragment",
    [
        ("  garage: {radar: 1}\n", "slots.garage", "unknown place"),
        ("  clock: {sonar: 1}\n", "slots.clock.sonar", "unknown kind"),
        ("  clock: {radar: -1}\n", "slots.clock.radar", "whole number"),
        ("  clock: {radar: 1.5}\n", "slots.clock.radar", "whole number"),
        ("  roof: 2\n", "slots.roof", "mapping of sensor type"),
    ],
)
def test_bad_slots_name_the_file_and_key(tmp_path, slots, key, fragment):
    path = _car(tmp_path, slots)
    with pytest.raises(LibraryError) as e:
        load_library(path)
    assert str(path) in str(e.value) and key in str(e.value) and fragment in str(e.value)


def test_bad_resources_name_the_model_and_key(tmp_path):
    text = (REPO / "configs" / "sensor_library.yaml").read_text().replace("power_w: 60 ", "power_w: -60 ", 1)
    p = tmp_path / "lib.yaml"
    p.write_text(text)
    with pytest.raises(LibraryError, match=r"models\[0\]\.resources\.power_w: must be 0 or more"):
        load_library(p)
    p.write_text(text.replace("power_w: -60 ", "Power W: 60 ", 1))
    with pytest.raises(LibraryError, match=r"models\[0\]\.resources\.Power W"):
        load_library(p)


def test_extends_loops_and_missing_bases_are_refused(tmp_path):
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    a.write_text("extends: b.yaml\n")
    b.write_text("extends: a.yaml\n")
    with pytest.raises(LibraryError, match="loop"):
        load_library(a)
    a.write_text("extends: nowhere.yaml\n")
    with pytest.raises(LibraryError, match=r"a\.yaml: extends: 'nowhere.yaml' not found"):
        load_library(a)


def test_a_mistake_in_the_base_is_reported_against_the_base(tmp_path):
    base = tmp_path / "base.yaml"
    base.write_text((REPO / "configs" / "sensor_library.yaml").read_text().replace("range_m: 120", "range_m: -1", 1))
    child = tmp_path / "child.yaml"
    child.write_text("extends: base.yaml\nslots:\n  roof: {lidar: 1}\n")
    with pytest.raises(LibraryError) as e:
        load_library(child)
    assert str(base) in str(e.value) and "models[0].range_m" in str(e.value)


def test_library_command_lists_resources_and_slots():
    r = CliRunner().invoke(cli, ["library", "--library", str(CAR)])
    assert r.exit_code == 0, r.output
    assert "power_w [W]" in r.output and "radar 1, stereo 1" in r.output and "lidar 2" in r.output
    j = CliRunner().invoke(cli, ["library", "--library", str(CAR), "--json"])
    import json

    doc = json.loads(j.output)
    assert doc["sensors"][0]["resources"]["power_w"] == 60.0
    assert {s["place"] for s in doc["slots"]} == {"roof", *[str(c) for c in range(1, 13)]}


def test_mounting_drawing_marks_full_slots():
    import matplotlib

    matplotlib.use("Agg")
    from sensorsel.plotting import plot_mounting

    car = load_library(CAR)
    suite = [car.position(x) for x in ("LRL-roof", "MRL-roof", "LRR-3", "HD2K-6")]
    ax = plot_mounting(car, suite)
    texts = {t.get_text(): t.get_color() for t in ax.texts}
    assert texts["L2/2"] == "tab:red"  # both roof LiDAR places taken
    assert texts["R1/1 C0/1"] == "tab:red"  # 3 o'clock: its radar slot is full
    assert texts["R0/1 C1/1"] == "tab:red"  # 6 o'clock: its camera slot is full
    empty = [t for t in ax.texts if t.get_text() == "R0/1 C0/1"]
    assert len(empty) == 10 and all(t.get_color() == "black" for t in empty)  # the ten other clock positions
    n_dots = len([ln for ln in ax.lines])
    assert n_dots == 13  # the roof and 12 clock positions
    assert np.isclose(ax.get_xlim()[1], 1.5)
    matplotlib.pyplot.close(ax.figure)
