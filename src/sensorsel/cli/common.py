"""Helpers the commands share that are not options: a suite read from ids or a result file, a
specification in metres from its options (``greedy``, ``pareto`` and ``require``), and what the commands
write: a result as JSON or its summary (:func:`echo_result`), what a command wrote (:func:`echo_written`),
the target, accuracy and limits lines and the tables."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import click

from sensorsel.api import PRESETS, Specification, load_specification_file, preset, specifications_for
from sensorsel.cli.options import path_option
from sensorsel.errors import InputError, ResultFileError
from sensorsel.io import results
from sensorsel.model.library import SensorLibrary
from sensorsel.model.problem import Problem, TargetInfo, check_result_problem

#: Result kinds that name a suite: simulate --suite/--compare read these (resilient ones also say
#: which sensors they assume to fail).
SUITE_KINDS = ("greedy", "resilient", "resilient-selection", "optimum", "score", "requirement")


def _is_file(path: Path) -> bool:
    """Whether ``path`` names an existing file; False for text no file system takes as a path (a long
    list of ids is longer than a file name may be: ENAMETOOLONG)."""
    try:
        return path.is_file()
    except OSError:
        return False


def is_result_file(text: str) -> bool:
    """Whether a suite option's value names a result file (``.json``, or an existing file) rather than ids."""
    return text.lower().endswith(".json") or _is_file(Path(text))


def read_suite(
    text: str,
    library: SensorLibrary,
    what: str,
    problem: Problem | None = None,
    force: bool = False,
    ignore: tuple[str, ...] = (),
) -> tuple[tuple[int, ...], str, tuple[str, ...]]:
    """A suite from comma-separated ids, or from a result file of a kind in :data:`SUITE_KINDS`
    (e.g. of ``sensorsel greedy -o`` or ``sensorsel resilient``), read by :func:`sensorsel.io.results.load`.
    With ``problem``, a result file must have been computed on it
    (:func:`~sensorsel.model.problem.check_result_problem`; ``force``: a warning instead).

    Returns:
        (library positions, label, sensors the result assumes to fail (resilient kinds)).
    Raises:
        ResultFileError: a file that cannot be read or is not a result of those kinds (names the kind found).
        InputError: an unknown id.
    """
    path = Path(text)
    if is_result_file(text):
        try:
            rec = results.load(path, SUITE_KINDS)
        except ResultFileError as exc:
            raise ResultFileError(path, f"{what}: {exc.reason}") from None
        ids: tuple[str, ...] = rec.suite
        if problem is not None:
            check_result_problem(
                _recorded_problem(rec),
                problem,
                path,
                force=force,
                what=f"{what}: the {results.kind_of(rec)} result",
                ignore=ignore,
            )
        failed: tuple[str, ...] = getattr(rec, "failed", ())
        try:
            positions = library.parse_suite(list(ids))
        except InputError as exc:
            raise ResultFileError(path, f"{what}: its suite: {exc} (a result of another library?)") from None
        return positions, path.stem, tuple(failed)
    try:
        return library.parse_suite(text), what.lstrip("-"), ()
    except InputError as exc:
        raise InputError(f"{what} {text!r}: {exc}") from None


def _recorded_problem(rec: Any) -> TargetInfo | None:
    """The target a suite result records (a resilient report's: its comparison's): a route's or a
    domain's, which :func:`~sensorsel.model.problem.check_result_problem` tells apart from this run's."""
    info: TargetInfo | None = getattr(rec, "problem", None)
    if info is None:
        info = getattr(getattr(rec, "comparison", None), "problem", None)
    return info


def specification_options(fn: Any) -> Any:
    """--preset, --lateral, --longitudinal, --heading, --sigma, --at, --spec: a specification in
    metres (read by :func:`specification_from`)."""
    for opt in reversed(
        [
            click.option(
                "--preset",
                default=None,
                metavar="|".join(PRESETS),
                help="A published specification: Reid et al. 2019, passenger cars, 95 %: local-streets 0.10 m lateral, "
                "0.10 m longitudinal, 0.17 deg heading; freeway 0.20 m, 0.48 m, 0.51 deg.",
            ),
            click.option(
                "--lateral", type=float, default=None, metavar="METRES", help="Bound on the lateral position error [m]."
            ),
            click.option(
                "--longitudinal",
                type=float,
                default=None,
                metavar="METRES",
                help="Bound on the longitudinal position error [m].",
            ),
            click.option(
                "--heading", type=float, default=None, metavar="DEGREES", help="Bound on the heading error [deg]."
            ),
            click.option("--sigma", is_flag=True, help="The bounds are 1σ (default: 95 % bounds, 1.96σ)."),
            click.option(
                "--at",
                type=float,
                default=None,
                metavar="PERCENT",
                help="Share of each route's keyframes that must meet every bound (default: 100, every keyframe).",
            ),
            path_option(
                "--spec",
                "spec_path",
                metavar="FILE",
                help="A specification file: a default and per-route specifications (a domain whose routes have "
                "different road classes); see the requirements guide.",
            ),
        ]
    ):
        fn = opt(fn)
    return fn


def specification_given(kw: dict[str, Any]) -> bool:
    """Whether any specification option was given."""
    return any(
        kw.get(k) not in (None, False)
        for k in ("preset", "lateral", "longitudinal", "heading", "sigma", "at", "spec_path")
    )


def specification_from(kw: dict[str, Any], routes: list[str]) -> list[Specification]:
    """Each route's specification from --preset, --lateral/--longitudinal/--heading, --sigma, --at
    and --spec (pops them from ``kw``)."""
    name, spec_path = kw.pop("preset"), kw.pop("spec_path")
    given = {k: kw.pop(k) for k in ("lateral", "longitudinal", "heading")}
    sigma, at = kw.pop("sigma"), kw.pop("at")
    if at is not None and not (0.0 < at <= 100.0):  # also refuses nan
        raise InputError(f"--at {at:g}: the share of keyframes must be above 0 % and at most 100 %")
    overrides: dict[str, Any] = {k: v for k, v in given.items() if v is not None}
    if sigma:
        overrides["sigma"] = True
    if at is not None:
        overrides["at"] = at / 100.0
    if spec_path is not None:
        if name is not None or any(v is not None for v in given.values()):
            raise click.UsageError(
                "--spec FILE gives the whole specification: drop --preset, --lateral, --longitudinal, --heading"
            )
        default, per_route = load_specification_file(spec_path)
        specs = specifications_for(routes, default, per_route, f"--spec {spec_path}")
        return [replace(s, **overrides) for s in specs] if overrides else specs
    if name is not None:
        base = preset(name)
        if overrides:
            base = replace(base, **overrides, name=f"{name} (changed)" if set(overrides) & set(given) else name)
        return [base] * len(routes)
    return [Specification(**overrides)] * len(routes)


# ------------------------------------------------------------------- what the commands write


def echo_written(kind: str, **fields: Any) -> None:
    """--json of a command that writes files rather than a result (scene, landmarks, osm, kitti): what
    it wrote, as one JSON object on stdout, its "kind" and "format" first like every result's."""
    import json

    click.echo(json.dumps({"kind": kind, "format": 1, **fields}, indent=2))


def table(rows: list[list[str]], header: list[str]) -> str:
    """Plain fixed-width table; numbers right-aligned."""
    cols = list(zip(*([header] + rows))) if rows else [(h,) for h in header]
    widths = [max(len(str(c)) for c in col) for col in cols]

    def fmt(row: list[str]) -> str:
        out = []
        for v, w in zip(row, widths):
            s = str(v)
            out.append(s.rjust(w) if _numeric(s) else s.ljust(w))
        return "  ".join(out).rstrip()

    return "\n".join([fmt(header), "  ".join("-" * w for w in widths)] + [fmt(r) for r in rows])


def _numeric(s: str) -> bool:
    try:
        float(s.replace(",", "").replace("$", "").replace("%", ""))
        return True
    except ValueError:
        return False


def print_target(info: TargetInfo | None) -> None:
    """The 'scenario' line (one route) or the 'domain' lines (each route) of a result; nothing when it
    records none."""
    if info is None:
        return
    if info.kind == "route":  # a route is named by its scenario, its problem is itself
        p = info.routes[0].problem
        when = f"; condition {p.condition}" if p.condition else ""
        click.echo(
            f"scenario   {p.scenario}: {p.n_poses} keyframes, {p.n_landmarks} landmarks ({p.landmark_source}){when}"
        )
        return
    conditions = list(dict.fromkeys(r.condition for r in info.routes if r.condition))
    routes = list(dict.fromkeys(r.route or r.name for r in info.routes))
    what = (
        f"{len(info.routes)} members ({len(routes)} routes x conditions {', '.join(conditions)})"
        if conditions
        else f"{len(info.routes)} routes"
    )
    click.echo(f"domain     {info.source}: {what}")  # the kind says it is a domain's
    for r in info.routes:
        p = r.problem
        click.echo(
            f"  {r.name:<12} weight {r.weight:g} {r.unit}; {p.n_poses} keyframes, {p.n_landmarks} landmarks "
            f"({p.landmark_source})"
        )


def compact_suite(suite: Sequence[str], library: SensorLibrary | None = None) -> str:
    """A suite for a table: ids grouped by model, ``LRL-roof HD2K-{2,4,12} LRR-6``; with ``library``,
    a suite of all but at most three of its sensors is ``all but LRL-roof`` (the full ids are in the JSON)."""
    if library is not None and len(suite) > 3:
        missing = [i for i in library.ids if i not in set(suite)]
        if len(missing) <= 3 and len(suite) + len(missing) == len(library):
            return "all but " + ", ".join(missing) if missing else f"all {len(library)} sensors"
    groups: dict[str, list[str]] = {}
    for sid in suite:
        code, _, where = sid.rpartition("-")
        groups.setdefault(code, []).append(where)
    return " ".join(f"{c}-{w[0]}" if len(w) == 1 else f"{c}-{{{','.join(w)}}}" for c, w in groups.items())


def print_limits(
    lib: SensorLibrary,
    budget_usd: float,
    constraints: Any,
    suite: Sequence[str],
    head: str = "limits     ",
    tail: str = "",
) -> None:
    """Under constraints (nothing when None): their description between ``head`` and ``tail``, then what
    ``suite`` uses of each limit (:func:`usage_table`) within ``budget_usd`` [$]."""
    if constraints is None:
        return
    from sensorsel.model.constraints import feasible_set

    click.echo(f"{head}{constraints.describe()}{tail}")
    click.echo(usage_table(feasible_set(lib, budget_usd, constraints).rows_used(lib.resolve_suite(suite))))


def usage_table(rows: Sequence[Any]) -> str:
    """The resource-use table of a constrained result: each limit, what the suite uses, what is left.
    ``rows`` are :class:`~sensorsel.model.constraints.RowUse`; mounting slots are summed into one line."""
    out, slots_used, slots_cap, full = [], 0.0, 0.0, 0
    for r in rows:
        if r.unit == "" and r.name != "sensors":
            slots_used += r.used
            slots_cap += r.limit
            full += int(r.used >= r.limit)
            continue

        def fmt(v: float, unit: str = r.unit) -> str:
            if unit == "$":
                return f"${v:,.0f}"
            return (f"{v:,.0f}" if abs(v) >= 1000 else f"{v:.4g}") + f" {unit}".rstrip()

        out.append([r.name, fmt(r.used), fmt(r.limit), f"{r.used / r.limit:.0%}" if r.limit > 0 else "-"])
    if slots_cap:
        out.append(["mounting slots", f"{slots_used:,.0f} sensors", f"{slots_cap:,.0f} places", f"{full} full"])
    return table(out, ["limit", "used", "of", "share"])


def echo_result(result: Any, as_json: bool, summary: Callable[[], None]) -> None:
    """What a command says of its result on stdout: with --json the result's JSON (its "kind" and
    "format" first), else ``summary()``, the lines a person reads."""
    if as_json:
        click.echo(results.dumps(result), nl=False)
    else:
        summary()


def print_accuracy(accuracies: Sequence[Any], integrity: Sequence[Any] = ()) -> None:
    """One line per route: the suite's 95 % errors in metres and degrees and the model behind them
    (:class:`~sensorsel.information.evaluators.accuracy.RouteAccuracy`); then one integrity line per
    route (:class:`~sensorsel.information.integrity.RouteIntegrity`), when computed."""
    for acc in accuracies:
        where = f" {acc.route}:" if len(accuracies) > 1 else ""
        click.echo(f"accuracy  {where} {acc.line()}")
    for itg in integrity:
        where = f" {itg.route}:" if len(integrity) > 1 else ""
        click.echo(f"integrity {where} {itg.line()}")
