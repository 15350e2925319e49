"""Specifications in metres: presets, verdicts by hand, files, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sensorsel.designs.requirements.spec import (
    PRESETS,
    Specification,
    SpecificationError,
    load_specification_file,
    preset,
    specifications_for,
    verdict,
)
from sensorsel.errors import InputError
from sensorsel.information.evaluators.accuracy import Z95, accuracy_from_covariances


def _accuracy(lateral, longitudinal=None, heading_deg=None):
    lat = np.asarray(lateral, float)
    cov = np.zeros((len(lat), 3, 3))
    cov[:, 1, 1] = lat**2
    cov[:, 0, 0] = (np.asarray(longitudinal, float) if longitudinal is not None else 0.01 * np.ones_like(lat)) ** 2
    cov[:, 2, 2] = (
        np.radians(np.asarray(heading_deg, float) if heading_deg is not None else 0.01 * np.ones_like(lat)) ** 2
    )
    return accuracy_from_covariances(cov, map_sigma_m=None, route="r")


def test_presets_are_reid_et_al():
    assert (
        PRESETS["local-streets"].lateral,
        PRESETS["local-streets"].longitudinal,
        PRESETS["local-streets"].heading,
    ) == (0.10, 0.10, 0.17)
    assert (PRESETS["freeway"].lateral, PRESETS["freeway"].longitudinal, PRESETS["freeway"].heading) == (
        0.20,
        0.48,
        0.51,
    )
    assert not PRESETS["freeway"].sigma and PRESETS["freeway"].at == 1.0
    with pytest.raises(InputError, match="--preset.*local-streets, freeway"):
        preset("city")


def test_verdict_by_hand():
    """A 95 % bound of 0.1 m is met by σ ≤ 0.1/1.96 = 0.0510 m; at 60 % of 5 keyframes, 3 must meet
    it: the 3rd smallest error (an order statistic), 1.96 × 0.05 = 0.098 m."""
    sig = [0.05, 0.051, 0.02, 0.06, 0.03]  # 1.96σ: 0.098, 0.09996, 0.039, 0.1176, 0.0588
    spec = Specification(lateral=0.1)
    v = verdict(_accuracy(sig), spec)
    assert not v.meets and v.worst[0][3] == (3,)  # only keyframe 3 fails
    assert v.violation == pytest.approx(Z95 * 0.06 / 0.1 - 1)
    assert verdict(_accuracy(sig), Specification(lateral=0.1, at=0.8)).meets  # 4 of 5 meet it
    assert not verdict(_accuracy(sig), Specification(lateral=0.097, at=0.6)).meets  # 3rd smallest: 0.098 > 0.097
    assert verdict(_accuracy(sig), Specification(lateral=0.0981, at=0.6)).meets
    assert verdict(_accuracy(sig), Specification(lateral=0.06, sigma=True)).meets  # 1σ bounds
    assert not verdict(_accuracy(sig), Specification(lateral=0.0599, sigma=True)).meets
    both = verdict(_accuracy(sig, heading_deg=[0.1] * 5), Specification(lateral=0.2, heading=0.17))
    assert not both.meets and both.worst[1][0] == "heading" and both.violation == pytest.approx(Z95 * 0.1 / 0.17 - 1)


def test_a_share_of_keyframes_that_is_not_a_whole_number_rounds_up():
    """--at P % of K keyframes with P·K not whole: "P % of the keyframes meet it" means at least
    P·K of them, so ⌈P·K⌉ (rounding down or to the nearest lets fewer meet it). The oracle counts,
    in whole numbers (count · 100 >= P · K), on every K up to 12 and every whole percent."""
    rng = np.random.default_rng(5)
    for k in range(1, 13):
        sig = rng.uniform(0.01, 0.1, size=k)
        for bound_sigma in sorted(sig):
            meeting = int(np.sum(sig <= bound_sigma))
            for percent in range(1, 101):
                got = verdict(
                    _accuracy(sig), Specification(lateral=float(bound_sigma), sigma=True, at=percent / 100)
                ).meets
                assert got == (meeting * 100 >= percent * k), (k, meeting, percent)
    # the case by hand: 50 % of 7 keyframes is 3.5, so 4 must meet; 3 meeting is not enough
    sig7 = [0.01, 0.02, 0.03, 0.09, 0.09, 0.09, 0.09]
    assert not verdict(_accuracy(sig7), Specification(lateral=0.05, sigma=True, at=0.5)).meets
    assert verdict(_accuracy(sig7), Specification(lateral=0.05, sigma=True, at=3 / 7)).meets


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(lateral=-0.1), "--lateral"),
        (dict(lateral=0.0), "--lateral"),
        (dict(longitudinal=math.nan), "--longitudinal"),
        (dict(heading=math.inf), "--heading"),
        (dict(lateral=0.1, at=0.0), "--at"),
        (dict(lateral=0.1, at=1.01), "--at"),
        ({}, "no requirement"),
    ],
)
def test_bad_specifications(kwargs, match):
    with pytest.raises(InputError, match=match):
        Specification(**kwargs)


def test_specification_file(tmp_path):
    f = tmp_path / "spec.yaml"
    f.write_text('preset: local-streets\nroutes:\n  "03": freeway\n  "00": {lateral: 0.15, at: 95}\n')
    default, per = load_specification_file(f)
    assert default == PRESETS["local-streets"]
    assert per["03"] == PRESETS["freeway"]
    assert per["00"].lateral == 0.15 and per["00"].longitudinal == 0.10 and per["00"].at == pytest.approx(0.95)
    specs = specifications_for(["03", "00", "10"], default, per)
    assert specs[2] == default
    with pytest.raises(InputError, match="route.*07.*not in the domain"):
        specifications_for(["03", "00"], default, {"07": default})


@pytest.mark.parametrize(
    "text, match",
    [
        ("preset: local-streets\ncolour: red\n", r"spec.yaml:2: colour: unknown key"),
        ("- 1\n- 2\n", "expected a mapping"),
        ("preset: city\n", "preset: unknown preset 'city'"),
        ("lateral: -1\n", "lateral: expected a finite number > 0"),
        ("lateral: 0.1\nat: 150\n", "at: expected a percentage"),
        ("lateral: '0.1'\n", "a number in quotes"),
        ("routes:\n  '03':\n    lateral: x\n", r"spec.yaml:3: routes.03.lateral"),
        ("preset: [unclosed\n", "malformed YAML"),
        ("sigma: 1\nlateral: 0.1\n", "sigma: expected true or false"),
    ],
)
def test_bad_specification_files(tmp_path, text, match):
    f = tmp_path / "spec.yaml"
    f.write_text(text)
    with pytest.raises(SpecificationError, match=match):
        load_specification_file(f)


def test_missing_specification_file(tmp_path):
    with pytest.raises(SpecificationError, match="specification file not found"):
        load_specification_file(tmp_path / "nope.yaml")
