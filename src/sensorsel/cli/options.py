"""Options shared by the commands, and the error handling every command runs under."""

from __future__ import annotations

import functools
import os
import sys
from typing import Any, Callable

import click

from ..errors import SensorselError
from ..problem import load_problem
from ..problem import Problem
from ..scenario import KITTI_ROOT_ENV, ScenarioSpec


def run(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Turn sensorsel's input errors into one clear line and exit code 2 (no traceback)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except SensorselError as exc:
            click.echo(f"sensorsel: error: {exc}", err=True)
            sys.exit(2)
        except KeyboardInterrupt:
            click.echo("sensorsel: interrupted", err=True)
            sys.exit(130)

    return wrapper


def scenario_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """--seq/--kitti-root/--poses/--times/--fixture/--landmarks/--landmark-seed/--rate/--library."""
    opts = [
        click.option("--seq", metavar="NN", help="KITTI odometry sequence (e.g. 03, 00); needs --kitti-root or $" + KITTI_ROOT_ENV + "."),
        click.option("--kitti-root", type=click.Path(file_okay=False, path_type=str), envvar=KITTI_ROOT_ENV, show_envvar=True,
                     help="KITTI odometry dataset/ folder (poses/NN.txt, sequences/NN/times.txt)."),
        click.option("--poses", type=click.Path(dir_okay=False, path_type=str), help="A route in KITTI's pose format (12 numbers a line)."),
        click.option("--times", type=click.Path(dir_okay=False, path_type=str), help="Timestamps for --poses (default: 10 Hz)."),
        click.option("--fixture", default="suburb", show_default=True, help="Bundled synthetic scenario used when neither --seq nor --poses is given."),
        click.option("--landmarks", type=click.Path(dir_okay=False, path_type=str), help="Landmark CSV (x,y in metres); default: generated (synthetic)."),
        click.option("--landmark-seed", type=int, default=0, show_default=True, help="Seed of the synthetic landmark generator."),
        click.option("--rate", "keyframe_rate_hz", type=float, default=1.0, show_default=True, help="Keyframe rate along the route [Hz]."),
        click.option("--library", "library_path", type=click.Path(dir_okay=False, path_type=str), help="Sensor library YAML (default: the paper's Table I)."),
    ]
    for opt in reversed(opts):
        fn = opt(fn)
    return fn


def spec_from(kw: dict[str, Any]) -> ScenarioSpec:
    """Pop the scenario options out of a command's keyword arguments."""
    if kw.get("poses") and kw.get("seq"):
        raise click.UsageError("give either --seq or --poses, not both")
    if kw.get("times") and not kw.get("poses"):
        # a --seq or a fixture reads its own times.txt: a --times here would be silently ignored
        raise click.UsageError(f"--times {kw['times']} goes with --poses FILE (a --seq or fixture has its own times.txt)")
    return ScenarioSpec(
        seq=kw.pop("seq"),
        kitti_root=kw.pop("kitti_root"),
        poses=kw.pop("poses"),
        times=kw.pop("times"),
        fixture=kw.pop("fixture"),
        landmarks=kw.pop("landmarks"),
        landmark_seed=kw.pop("landmark_seed"),
        keyframe_rate_hz=kw.pop("keyframe_rate_hz"),
    )


def problem_from(kw: dict[str, Any]) -> Problem:
    """Load the library and scenario named by the options (pops them from ``kw``); the problem
    records them as its provenance."""
    spec = spec_from(kw)
    return load_problem(spec, kw.pop("library_path"))


def engine_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """--engine and --jobs."""
    from ..objective import ENGINES

    fn = click.option("--jobs", type=click.IntRange(min=1), default=os.cpu_count() or 1, show_default="all cores",
                      help="Threads scoring candidate suites in parallel, fast engine (results do not depend on it).")(fn)
    fn = click.option("--engine", type=click.Choice(sorted(ENGINES)), default=None,
                      help="Scoring engine (default: the fastest; 'reference' rebuilds the GTSAM graph per suite).")(fn)
    return fn


class _Bar:
    """progress(done, total) -> a click progress bar on stderr; ``phases`` runs fill one bar in turn.

    ``after``: a bar of the previous stage of the same run, completed when this one starts (so two
    bars never draw over each other).
    """

    def __init__(self, label: str, phases: int = 1, after: "_Bar | None" = None) -> None:
        self.label, self.phases, self.after = label, phases, after
        self.bar: Any = None
        self.offset = self.last = self.last_total = 0

    def __enter__(self) -> "_Bar":
        return self

    def __call__(self, done: int, total: int) -> None:
        if self.bar is False:  # closed
            return
        if self.bar is None:
            if self.after is not None:
                self.after.__exit__(None, None, None)
            self.bar = click.progressbar(length=max(1, total * self.phases), label=self.label, file=sys.stderr,
                                         show_pos=True)
            self.bar.__enter__()
        if done < self.last:  # the next phase (best-of: the marginal run after the uniform one)
            self.offset += self.last_total
        self.last, self.last_total = done, total
        self.bar.length = max(1, self.offset + total, self.phases * total)
        self.bar.pos = min(self.bar.length, self.offset + done)
        self.bar.render_progress()

    def __exit__(self, *exc: Any) -> None:
        """Complete and close the bar (once; later calls do nothing)."""
        if self.bar is not None and self.bar is not False:
            if exc[0] is None:  # the totals are upper bounds: show the run as complete
                self.bar.pos = self.bar.length
                self.bar.render_progress()
            self.bar.__exit__(*exc)
            self.bar = False  # closed: never reopened by a late progress call
        elif self.bar is None:
            self.bar = False


def progress_bar(quiet: bool, label: str, phases: int = 1, after: _Bar | None = None) -> tuple[_Bar | None, Callable[[int, int], None] | None]:
    """(bar, progress): a progress bar on stderr, used as ``with bar:`` around the run that calls
    ``progress(done, total)``; (None, None) with --quiet or when stderr is not a terminal. ``after``:
    the bar of the previous stage, completed when this one starts."""
    if quiet or not sys.stderr.isatty():
        return None, None
    bar = _Bar(label, phases, after)
    return bar, bar


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

