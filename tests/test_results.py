"""Result files carry their kind and format; typed loading refuses anything else."""

from __future__ import annotations

import ast
import inspect
import json
import re

import pytest

from sensorsel.api import ScoreResult, run_greedy, score_suite
from sensorsel.designs.certify import CertifiedGreedyResult
from sensorsel.designs.selection import GreedyResult
from sensorsel.errors import ResultFileError
from sensorsel.io import codec, results


@pytest.fixture(scope="module")
def score(tiny_problem) -> ScoreResult:
    return score_suite(tiny_problem, "LRL-roof,LRR-12", engine="reference")


@pytest.fixture(scope="module")
def greedy_result(tiny_problem) -> GreedyResult:
    return run_greedy(tiny_problem, 5000.0, "marginal", engine="reference", jobs=1)


def test_every_kind_names_an_importable_record_class():
    for kind in results.KINDS:
        cls = results.record_class(kind)
        assert results.kind_of(cls) == kind


def test_written_files_start_with_kind_and_format(score, tmp_path):
    path = results.save(score, tmp_path / "s.json")
    data = json.loads(path.read_text())
    assert list(data)[:2] == ["kind", "format"]
    assert data["kind"] == "score" and data["format"] == results.FORMAT
    assert results.load(path, ScoreResult) == score
    assert results.load(path, "score") == score
    assert results.load(path) == score  # any kind: the file says which
    with pytest.raises(TypeError):  # one argument order: the file first
        results.load(ScoreResult, path)  # type: ignore[call-overload]


def test_a_compact_file_is_one_line_of_the_same_json_and_loads_the_same(greedy_result, tmp_path):
    """A checkpoint is written on one line (the C encoder): the same JSON values, in the same key
    order, as the indented file, and the same record read back."""
    wide, narrow = results.save(greedy_result, tmp_path / "g.json"), tmp_path / "g1.json"
    results.save(greedy_result, narrow, compact=True)
    text = narrow.read_text()
    assert text.count("\n") == 1 and text.endswith("\n") and len(text) < len(wide.read_text())
    assert list(json.loads(text).items()) == list(json.loads(wide.read_text()).items())
    assert results.load(narrow) == results.load(wide) == greedy_result


def test_leaves_convert_as_the_generic_path_does():
    """The exact-type shortcuts of to_jsonable give what its generic path gives: a bool stays a bool
    (not 1), a non-finite float a string, a tuple of tuples nested lists, an int subclass itself."""
    import enum

    class Level(enum.IntEnum):
        LOW = 1

    got = codec.to_jsonable((True, 1, 2.5, float("inf"), float("nan"), None, "x", ((1, 2), [3]), Level.LOW))
    assert got == [True, 1, 2.5, "inf", "nan", None, "x", [[1, 2], [3]], Level.LOW]
    assert type(got[0]) is bool and type(got[1]) is int


def test_a_file_of_another_kind_is_refused_naming_the_file_and_both_kinds(score, tmp_path):
    path = results.save(score, tmp_path / "score.json")
    with pytest.raises(ResultFileError) as exc:
        results.load(path, GreedyResult)
    msg = str(exc.value)
    assert str(path) in msg and "'score'" in msg and "'greedy'" in msg
    with pytest.raises(ResultFileError, match=r"expected a 'greedy' or 'resilient' result"):
        results.load(path, ("greedy", "resilient"))


def test_a_newer_format_is_refused(score, tmp_path):
    path = tmp_path / "new.json"
    data = json.loads(results.dumps(score))
    data["format"] = results.FORMAT + 1
    path.write_text(json.dumps(data))
    with pytest.raises(ResultFileError, match=re.escape(f"format {results.FORMAT + 1}") + ".*newer sensorsel"):
        results.load(path, ScoreResult)


def test_an_unknown_kind_is_refused(tmp_path):
    path = tmp_path / "x.json"
    path.write_text(json.dumps({"kind": "hologram", "format": 1}))
    with pytest.raises(ResultFileError, match="'hologram', a kind this sensorsel does not know"):
        results.load(path, "score")


def test_old_files_without_kind_load_when_they_parse_as_the_expected_class(score, greedy_result, tmp_path):
    """Read by sensorsel.io.legacy until the release it names."""
    old = tmp_path / "old.json"
    old.write_text(codec.dumps(score))  # what results.save wrote before kinds
    assert "kind" not in json.loads(old.read_text())
    assert results.load(old, ScoreResult) == score
    old_greedy = tmp_path / "old_greedy.json"
    old_greedy.write_text(codec.dumps(greedy_result))
    assert results.load(old_greedy, CertifiedGreedyResult) == greedy_result
    # an old file of another class does not parse as the expected one: refused, naming the file
    with pytest.raises(ResultFileError) as exc:
        results.load(old, GreedyResult)
    assert str(old) in str(exc.value) and "'greedy'" in str(exc.value)
    # a class whose fields all have defaults would accept any object: keys it lacks are refused
    with pytest.raises(ResultFileError, match="no field"):
        results.load(old, "simulation")


def test_unregistered_classes_are_not_result_kinds(tmp_path):
    from sensorsel.model.problem import GraphSettings

    with pytest.raises(TypeError, match="not a result kind"):
        results.save(GraphSettings(), tmp_path / "g.json")


def test_codec_is_a_base_layer_module():
    """codec.py imports nothing of sensorsel but errors and files."""
    tree = ast.parse(inspect.getsource(codec))
    local = {
        n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("sensorsel")
    }
    assert local and local <= {"sensorsel.errors", "sensorsel.io.files"}, local


def test_resume_reads_period_files_by_kind(tiny_problem, tmp_path):
    """resilient --resume reuses a period file of kind 'resilient-period' (or one written before kinds),
    and recomputes one whose kind is another (never misreads it)."""
    from sensorsel.designs.resilient import period_file, resilient_report

    def report(resume):
        return resilient_report(
            tiny_problem, 5000.0, 1, period_s=3.0, engine="reference", outdir=tmp_path, resume=resume
        )

    first = report(False)
    p0, p1 = (
        period_file(tmp_path, first.per_period.periods[0].period.index),
        period_file(tmp_path, first.per_period.periods[1].period.index),
    )
    assert json.loads(p0.read_text())["kind"] == "resilient-period"
    data = json.loads(p0.read_text())
    p0.write_text(json.dumps({k: v for k, v in data.items() if k not in ("kind", "format")}))  # an old file
    other = json.loads(p1.read_text())
    p1.write_text(json.dumps({**other, "kind": "resilient-comparison"}))  # right fields, wrong kind
    before = p0.stat().st_mtime_ns
    from sensorsel.designs.resilient import CacheWarning

    with pytest.warns(CacheWarning, match=f"{p1}.*'resilient-comparison'") as caught:
        again = report(True)
    assert len(caught) == 1  # the old file without a kind is reused silently
    assert [(p.fingerprint, p.result.suite) for p in again.per_period.periods] == [
        (p.fingerprint, p.result.suite) for p in first.per_period.periods
    ]
    assert p0.stat().st_mtime_ns == before  # reused
    assert json.loads(p1.read_text())["kind"] == "resilient-period"  # recomputed and rewritten
