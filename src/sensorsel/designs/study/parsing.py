"""A design study's YAML file, validated with key paths and lines."""

from __future__ import annotations

import itertools
from dataclasses import replace
from pathlib import Path
from typing import Any

from sensorsel.designs.resilient import METHODS  # METHODS: how a cell with failures chooses
from sensorsel.designs.selection import RULES, check_affordable
from sensorsel.designs.study.records import DEFAULT_LIBRARY, Cell, Study, StudyError, TargetFiles
from sensorsel.errors import SensorselError
from sensorsel.information.evaluators import ENGINES
from sensorsel.information.evaluators.domain import AGGREGATES
from sensorsel.io.inputs import Checker, Map, Seq, read_yaml
from sensorsel.model.domain import ROUTE_KEYS, SYNTHETIC, load_domain_file, parse_route
from sensorsel.model.library import load_library
from sensorsel.model.scenario import ScenarioSpec

_TOP_KEYS = ("target", "grid", "engine", "method", "certificate")
_TARGET_KEYS = (
    "fixture",
    "seq",
    "kitti_root",
    "route",
    "format",
    "times",
    "landmarks",
    "rate",
    "clearance_m",
    "name",
    "domain",
    "aggregate",
)
_GRID_KEYS = ("budgets", "rules", "failures", "landmark_seeds", "libraries")


# ------------------------------------------------------------------------------------------ parsing


def _list(c: Checker, m: Map, key: str, default: list[Any] | None) -> tuple[list[Any], list[int]]:
    """The list under ``grid.key`` and each item's line (``default`` when absent; required when None)."""
    if key not in m:
        if default is None:
            c.fail(f"grid.{key}", "missing: expected a non-empty list", m.line)
        return list(default), [m.line] * len(default)
    v = m[key]
    if not isinstance(v, Seq) or not v:
        c.fail(f"grid.{key}", f"expected a non-empty list, e.g. [a, b], got {v!r}", m.lines[key])
    return list(v), list(v.lines)


def _budget(c: Checker, value: Any, key: str, line: int) -> float:
    if isinstance(value, str):
        text = value.strip().replace("$", "").replace(",", "").replace("_", "")
        try:
            value = float(text)
        except ValueError:
            c.fail(key, f'expected a number of dollars (5000, "$110,000"), got {value!r}', line)
    return c.number(value, key, line, strict=False)


def _unique(c: Checker, items: list[Any], lines: list[int], key: str) -> None:
    seen: dict[Any, int] = {}
    for i, (v, ln) in enumerate(zip(items, lines)):
        if v in seen:
            c.fail(f"grid.{key}[{i}]", f"{v!r} repeated (also grid.{key}[{seen[v]}]): every cell would run twice", ln)
        seen[v] = i


def parse_study(data: Any, path: str | Path = "<memory>") -> Study:
    """Validate a parsed study document (as :func:`load_study` reads it) and resolve its paths.

    Raises:
        StudyError: naming ``path``, the key path and the line of the first problem found.
    """
    path = Path(path)
    c = Checker(path, StudyError)
    if not isinstance(data, Map):
        c.fail("", f"expected a mapping with target and grid, got {type(data).__name__}", getattr(data, "line", None))
    c.keys(data, "", _TOP_KEYS)
    for k in ("target", "grid"):
        if k not in data:
            c.fail(k, "missing", data.line)
    engine = data.get("engine")
    if "engine" in data and engine not in ENGINES:
        c.fail("engine", f"unknown engine {engine!r}; available: {', '.join(sorted(ENGINES))}", data.lines["engine"])
    method = data.get("method", METHODS[0])
    if method not in METHODS:
        c.fail("method", f"expected one of {', '.join(METHODS)}, got {method!r}", data.lines["method"])
    cert = data.get("certificate", True)
    if not isinstance(cert, bool):
        c.fail("certificate", f"expected true or false, got {cert!r}", data.lines["certificate"])
    spec, domain, aggregate, fixed_seed = _parse_target(c, data["target"], data.lines["target"])

    grid = data["grid"]
    if not isinstance(grid, Map):
        c.fail(
            "grid",
            f"expected a mapping (budgets, rules, failures, landmark_seeds, libraries), got {grid!r}",
            data.lines["grid"],
        )
    c.keys(grid, "grid", _GRID_KEYS)
    raw_budgets, b_lines = _list(c, grid, "budgets", None)
    budgets = [_budget(c, v, f"grid.budgets[{i}]", ln) for i, (v, ln) in enumerate(zip(raw_budgets, b_lines))]
    _unique(c, budgets, b_lines, "budgets")
    rules, r_lines = _list(c, grid, "rules", ["uniform"])
    for i, (r, ln) in enumerate(zip(rules, r_lines)):
        if r not in RULES:
            c.fail(f"grid.rules[{i}]", f"unknown rule {r!r}; available: {', '.join(RULES)}", ln)
    _unique(c, rules, r_lines, "rules")
    failures, f_lines = _list(c, grid, "failures", [0])
    for i, (a, ln) in enumerate(zip(failures, f_lines)):
        if isinstance(a, bool) or not isinstance(a, int) or a < 0:
            c.fail(f"grid.failures[{i}]", f"expected an integer >= 0 (sensors that may fail), got {a!r}", ln)
    _unique(c, failures, f_lines, "failures")
    seeds: list[int | None] = [None]
    s_lines = [grid.line]
    if "landmark_seeds" in grid:
        line = grid.lines["landmark_seeds"]
        if domain is not None:
            c.fail(
                "grid.landmark_seeds",
                "a domain's routes name their own landmarks (its file): seeds go with one route",
                line,
            )
        if spec is None or spec.landmarks != SYNTHETIC:
            c.fail("grid.landmark_seeds", "seeds choose synthetic maps: give target.landmarks: synthetic", line)
        if fixed_seed:
            c.fail(
                "grid.landmark_seeds",
                "target.landmarks fixes its seed ({synthetic: {seed: N}}): give the seeds "
                "in one place (target.landmarks: synthetic)",
                line,
            )
        raw_seeds, s_lines = _list(c, grid, "landmark_seeds", None)
        for i, (s, ln) in enumerate(zip(raw_seeds, s_lines)):
            if isinstance(s, bool) or not isinstance(s, int) or s < 0:
                c.fail(f"grid.landmark_seeds[{i}]", f"expected an integer >= 0, got {s!r}", ln)
        _unique(c, raw_seeds, s_lines, "landmark_seeds")
        seeds = list(raw_seeds)
    libs, l_lines = _list(c, grid, "libraries", [DEFAULT_LIBRARY])
    lib_paths: list[str | None] = []
    for i, (lib, ln) in enumerate(zip(libs, l_lines)):
        key = f"grid.libraries[{i}]"
        lib_paths.append(None if lib == DEFAULT_LIBRARY else c.file(lib, key, ln))
        libs[i] = c.string(lib, key, ln)
    _unique(c, libs, l_lines, "libraries")

    targets: list[TargetFiles] = []
    cells: list[Cell] = []
    for (lib, lib_path), seed in itertools.product(zip(libs, lib_paths), seeds):
        t = len(targets)
        targets.append(
            TargetFiles(
                replace(spec, landmark_seed=seed) if spec is not None and seed is not None else spec, domain, lib_path
            )
        )
        for alpha, rule, budget in itertools.product(failures, rules, budgets):
            cells.append(Cell(len(cells), lib, seed, alpha, rule, budget, t))
    _check_budgets(c, cells, targets, budgets, b_lines, failures, f_lines)
    return Study(str(path), tuple(targets), tuple(cells), engine, aggregate, method, cert)


def _parse_target(c: Checker, raw: Any, line: int) -> tuple[ScenarioSpec | None, str | None, str, bool]:
    """(route spec or None, domain file or None, aggregate, whether the landmarks fix a seed)."""
    if not isinstance(raw, Map):
        c.fail("target", f"expected a mapping (fixture, seq or route, landmarks, rate; or domain), got {raw!r}", line)
    c.keys(raw, "target", _TARGET_KEYS)
    ln = lambda k: raw.lines.get(k, raw.line)  # noqa: E731
    if "domain" in raw:
        other = [k for k in raw if k not in ("domain", "aggregate")]
        if other:
            c.fail(
                f"target.{other[0]}",
                "a domain file lists its own routes, landmarks and rate: give domain alone (with aggregate)",
                ln(other[0]),
            )
        agg = raw.get("aggregate", AGGREGATES[0])
        if agg not in AGGREGATES:
            c.fail("target.aggregate", f"expected one of {', '.join(AGGREGATES)}, got {agg!r}", ln("aggregate"))
        return None, c.file(raw["domain"], "target.domain", ln("domain")), agg, False
    if "aggregate" in raw:
        c.fail("target.aggregate", "combines a domain's routes: it goes with target.domain", ln("aggregate"))
    rate = c.number(raw["rate"], "target.rate", ln("rate")) if "rate" in raw else 1.0
    clearance = (
        c.number(raw["clearance_m"], "target.clearance_m", ln("clearance_m"), strict=False)
        if "clearance_m" in raw
        else None
    )
    name = c.string(raw["name"], "target.name", ln("name")) if "name" in raw else None
    route = Map({k: v for k, v in raw.items() if k in ROUTE_KEYS})
    route.line, route.lines = raw.line, raw.lines
    route["name"] = name or "target"
    r = parse_route(c, route, "target", line, ScenarioSpec(keyframe_rate_hz=rate, clearance_m=clearance), None, "hours")
    landmarks = raw.get("landmarks")
    return replace(r.spec, name=name), None, "", isinstance(landmarks, Map)


def _check_budgets(
    c: Checker,
    cells: list[Cell],
    targets: list[TargetFiles],
    budgets: list[float],
    b_lines: list[int],
    failures: list[int],
    f_lines: list[int],
) -> None:
    """Every budget must buy a sensor (more than alpha of them) from every library of the grid, as
    a command's --budget must (:func:`sensorsel.designs.selection.check_affordable`)."""
    seen: set[tuple[str, int, float]] = set()
    for cell in cells:
        lib_path = targets[cell.target].library
        if (cell.library, cell.failures, cell.budget_usd) in seen:
            continue
        seen.add((cell.library, cell.failures, cell.budget_usd))
        if targets[cell.target].domain is not None and lib_path is None:
            lib_path = load_domain_file(targets[cell.target].domain or "").library
        lib = load_library(lib_path)
        i, j = budgets.index(cell.budget_usd), failures.index(cell.failures)
        try:
            check_affordable(lib, cell.budget_usd, cell.failures, budget_option="budget", alpha_option="failures")
        except SensorselError as exc:
            where = f" (library {cell.library})" if cell.library != DEFAULT_LIBRARY else ""
            if str(exc).startswith("failures"):
                c.fail(f"grid.failures[{j}]", f"{exc}{where}", f_lines[j])
            c.fail(f"grid.budgets[{i}]", f"{exc}{where}", b_lines[i])


def load_study(path: str | Path) -> Study:
    """Read and validate a study YAML file (see the module's documentation).

    Raises:
        StudyError: missing file, malformed YAML, an unknown key, a wrong type or value, a missing
            file it names, a budget that buys nothing (each naming the file, the key path and the line).
    """
    path = Path(path)
    return parse_study(read_yaml(path, StudyError, "study file"), path)
