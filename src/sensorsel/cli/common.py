"""Helpers the commands share that are not options: a suite read from ids or a result file, and a
specification in metres from its options (``greedy``, ``pareto`` and ``require``)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import click

from sensorsel.api import PRESETS, Specification, load_specification_file, preset, specifications_for
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
            click.option(
                "--spec",
                "spec_path",
                type=click.Path(dir_okay=False, path_type=str),
                default=None,
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
