"""Result records composed of the small parts in ``sensorsel.io.records``: their fields, and so their JSON,
in the order the published files have them (the oracle: the key order of every published result file,
written before the records were composed), and a record rewritten to the same bytes."""

from __future__ import annotations

import dataclasses
import json
import typing
from pathlib import Path

import pytest

from sensorsel.designs.parts import Provenance, SuiteQuality
from sensorsel.errors import ResultFileError
from sensorsel.io import codec, records, results
from sensorsel.io.codec import json_fields, last
from sensorsel.io.results import record_class as kind_class

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "results"
PUBLISHED = sorted(
    p for p in RESULTS.rglob("*.json") if isinstance(d := json.loads(p.read_text()), dict) and d.get("kind")
)
COMPOSED = (
    "greedy",
    "certificate",
    "optimum",
    "score",
    "domain-score",
    "tradespace",
    "robust",
    "robust-optimum",
    "resilient-selection",
    "resilient-comparison",
)


@dataclasses.dataclass(frozen=True)
class _Head:
    a: int
    b: str


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Tail:
    t: float = last(0.5)
    u: tuple[int, ...] = last(())


@dataclasses.dataclass(frozen=True)
class _Record(_Tail, _Head):
    c: bool


def _keys_in_order(obj, cls, where: str) -> None:
    """A record's keys that are its class's fields are in the order its JSON has them (its fields in
    order, those of the parts it ends with last: ``codec.json_fields``; a file written before a field
    was added lacks it; one of an older version may name a field otherwise)."""
    names = [f.name for f in json_fields(cls)]
    keys = [k for k in obj if k in names]
    assert len(keys) >= len(names) // 2 and [n for n in names if n in keys] == keys, f"{where}: {keys} against {names}"


def test_the_published_files_cover_the_composed_records():
    kinds = {json.loads(p.read_text())["kind"] for p in PUBLISHED}
    assert {"greedy", "certificate", "optimum", "score", "domain-score", "tradespace", "robust"} <= kinds


@pytest.mark.parametrize("path", PUBLISHED, ids=lambda p: str(p.relative_to(RESULTS)))
def test_a_published_file_has_its_kinds_fields_in_order_and_reads_back_to_its_bytes(path):
    data = json.loads(path.read_text())
    cls = kind_class(data["kind"])
    _keys_in_order(data, cls, str(path))
    try:
        obj = results.load(path, cls)
    except ResultFileError as e:  # a published result that cannot be read back is a bug: regenerate it
        pytest.fail(f"{e} (regenerate it: python docs/regenerate.py --only STEP --maps real|synthetic)")
    again = json.loads(results.dumps(obj))
    kept = [k for k in data if k in again]
    assert [k for k in again if k in data] == kept and len(kept) >= len(again) // 2, path


def test_every_composed_kind_holds_its_parts_fields_as_one_run_in_the_parts_order():
    parts = [c for c in vars(records).values() if isinstance(c, type) and dataclasses.is_dataclass(c)]
    seen = 0
    for kind in COMPOSED:
        cls = kind_class(kind)
        names = [f.name for f in dataclasses.fields(cls)]
        for part in parts:
            if issubclass(cls, part):
                run = [f.name for f in dataclasses.fields(part)]
                start = names.index(run[0])
                assert names[start : start + len(run)] == run, (kind, part.__name__)
                seen += 1
    assert seen >= len(COMPOSED)


def test_part_of_copies_a_parts_fields_from_a_record_that_holds_it():
    """A robust candidate's MethodWorst part, read by name, builds the part back field for field, and a
    record made of more fields gives only the part's (the oracle: the fields written out by hand)."""
    from sensorsel.designs.robust.records import Candidate

    c = Candidate(
        method="saturate",
        suite=("a", "b"),
        cost_usd=3.0,
        nominal_score=5.0,
        worst_score=2.0,
        failures=("b",),
        note="n",
        n_evaluations=7,
    )
    got = records.part_of(c, records.MethodWorst)
    # the order io/records.py documents: the last part's fields first (method), then WorstOutcome's
    assert list(got) == ["method", "suite", "cost_usd", "nominal_score", "worst_score", "failures"]
    assert got == {
        "suite": ("a", "b"),
        "cost_usd": 3.0,
        "nominal_score": 5.0,
        "worst_score": 2.0,
        "failures": ("b",),
        "method": "saturate",
    }
    assert records.part_of(c, records.SuiteCost) == {"suite": ("a", "b"), "cost_usd": 3.0}


def test_fields_made_with_last_are_written_after_the_others_and_read_back():
    """A part of :func:`codec.last` fields is a base (its fields first in the class) and still the end
    of the JSON; the record reads back equal (the oracle: the key order written out by hand)."""
    r = _Record(a=1, b="x", c=True, t=2.0, u=(3,))
    assert [f.name for f in dataclasses.fields(r)] == ["a", "b", "t", "u", "c"]
    text = codec.dumps(r)
    assert list(json.loads(text)) == ["a", "b", "c", "t", "u"]
    assert codec.from_jsonable(_Record, json.loads(text)) == r
    assert codec.from_jsonable(_Record, {"a": 1, "b": "x", "c": False}) == _Record(1, "x", False)
    with pytest.raises(TypeError):  # keyword-only: a part's field is never taken by position
        _Record(1, "x", True, 2.0)  # type: ignore[misc]


@pytest.mark.parametrize("kind", sorted(results.KINDS))
def test_a_kind_holding_the_run_or_the_suite_quality_fields_composes_their_part(kind):
    """``problem, seconds, constraints`` and ``accuracy, integrity`` (of the parts' types) come from one
    place each (:mod:`sensorsel.designs.parts`), not written out again in a record."""
    cls = kind_class(kind)
    hints = typing.get_type_hints(cls)
    names = [(f.name, hints[f.name]) for f in json_fields(cls)]
    for part in (Provenance, SuiteQuality):
        part_hints = typing.get_type_hints(part)
        run = [(f.name, part_hints[f.name]) for f in dataclasses.fields(part)]
        at = [i for i in range(len(names)) if names[i : i + len(run)] == run]
        if at:
            assert issubclass(cls, part), f"{kind}: {cls.__name__} writes {run} out, not composing {part.__name__}"
            assert all(f.metadata == codec.LAST for f in dataclasses.fields(cls) if (f.name, hints[f.name]) in run)
