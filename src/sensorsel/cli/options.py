"""Options shared by the commands, and the error handling every command runs under.

Every command that takes a budget uses :func:`budget_option` (110000, 110,000, $110,000, 110_000);
every command ends with :func:`result_options`: --json (the result's JSON on stdout), -q/--quiet and
--progress/--no-progress (progress drawn with :func:`~sensorsel.cli.progress.progress_bar`), and the
error handling of :func:`run`; every design command starts with :func:`design_options`, read by
:func:`design_from` (its target, cluster, limits, scoring and reporting); every command that draws a
plot has :func:`plot_format_option` (--plot-format png|svg|pdf; default: a file output's extension, else
png); every -o/--output FILE and --output-dir DIRECTORY uses :func:`output_option`, which refuses an
empty name. The names and meanings are those of :mod:`sensorsel.cli.vocabulary`.
"""

from __future__ import annotations

import functools
import math
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar, cast

import click

from sensorsel.api import AGGREGATES, ESTIMATES, checkpoint_path, with_suite_quality
from sensorsel.cli.integrity import integrity_from, integrity_options
from sensorsel.cli.progress import progress_bar, progress_flag  # noqa: F401 (progress_bar: the commands import it from here)
from sensorsel.cli.vocabulary import TopicOption
from sensorsel.errors import InputError, SensorselError, SensorselWarning
from sensorsel.io import results
from sensorsel.io.files import output_dir, output_file
from sensorsel.model.conditions import parse_condition
from sensorsel.model.problem import Problem, Target, load_domain, load_problem
from sensorsel.model.scenario import DEFAULT_OSM_REACH_M, KITTI_ROOT_ENV, ROUTE_FORMATS, ScenarioSpec


class Terminated(KeyboardInterrupt):
    """SIGTERM (a batch system's time limit, ``kill``, a container stopping), raised where the command
    is as Ctrl-C is: what a run keeps on its way out (a journal, a checkpoint, its workers stopped) is
    done as after an interrupt, where Python's default would end the process on the spot."""


@contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """Within: SIGTERM raises :class:`Terminated` once (a second one ends the process at once, as by
    default: the way out may be what hangs). Only in the main thread, where signals are handled,
    and not where the process was started with SIGTERM ignored (as Python leaves an ignored SIGINT)."""
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGTERM) == signal.SIG_IGN:
        yield
        return

    def terminate(signum: int, frame: Any) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        raise Terminated()

    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Turn sensorsel's input errors into one clear line and exit code 2 (no traceback); print
    sensorsel's warnings (:class:`~sensorsel.errors.SensorselWarning`) as one line
    ``sensorsel: warning: ...`` on stderr; Ctrl-C and SIGTERM end the command as an interrupt
    (exit 130 and 143, what it keeps written)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("always", SensorselWarning)
                shown = warnings.showwarning

                def show(message: Any, category: type[Warning], *rest: Any, **kw: Any) -> None:
                    if issubclass(category, SensorselWarning):
                        click.echo(f"sensorsel: warning: {message}", err=True)
                    else:
                        shown(message, category, *rest, **kw)

                warnings.showwarning = show
                with _sigterm_as_interrupt():
                    return fn(*args, **kwargs)
        except SensorselError as exc:
            click.echo(f"sensorsel: error: {exc}", err=True)
            sys.exit(2)
        except Terminated:
            click.echo("sensorsel: terminated", err=True)
            sys.exit(143)  # 128 + SIGTERM, as a shell reports a process the signal ended
        except KeyboardInterrupt:
            click.echo("sensorsel: interrupted", err=True)
            sys.exit(130)

    return wrapper


F = TypeVar("F", bound=Callable[..., Any])


class BudgetType(click.ParamType):
    """A budget in dollars: ``110000``, ``110,000``, ``$110,000`` or ``110_000``; finite and >= 0."""

    name = "DOLLARS"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            v = float(value)
        else:
            text = str(value).strip().replace("$", "").replace(",", "").replace("_", "")
            try:
                v = float(text)
            except ValueError:
                self.fail(f"{value!r} is not a number of dollars (e.g. 110000)", param, ctx)
        if not math.isfinite(v) or v < 0:
            self.fail(f"{value!r}: a budget must be a finite, non-negative number of dollars", param, ctx)
        return v


BUDGET = BudgetType()


def budget_option(
    *,
    required: bool = False,
    default: float | None = None,
    multiple: bool = False,
    help: str = "Budget in dollars: 110000, 110,000, $110,000 or 110_000.",
) -> Callable[[F], F]:
    """--budget DOLLARS, parsed by :class:`BudgetType`."""
    # no default=None: click 8.5 takes an explicit None for a given default, and a required
    # --budget left out then reached the command as None instead of "Missing option '--budget'"
    extra: dict[str, Any] = {} if default is None else {"default": default, "show_default": True}
    return click.option("--budget", type=BUDGET, required=required, multiple=multiple, help=help, **extra)


def lazy_option(fn: F) -> F:
    """--lazy/--no-lazy: lazy (Minoux) greedy evaluation, on unless --no-lazy."""
    return click.option(
        "--lazy/--no-lazy",
        default=True,
        show_default=True,
        help="Lazy (Minoux) evaluation: same picks, fewer evaluations.",
    )(fn)


def quiet_option(fn: F) -> F:
    """-q/--quiet and --progress/--no-progress (:mod:`sensorsel.cli.progress`)."""
    return click.option(
        "-q",
        "--quiet",
        is_flag=True,
        help="No progress on stderr (unless --progress); errors and warnings are still said.",
    )(progress_flag(fn))


def result_options(fn: F) -> F:
    """What every command ends with: --json (:func:`json_option`), -q/--quiet and --progress
    (:func:`quiet_option`), and its errors said in one line (:func:`run`)."""
    return json_option(quiet_option(cast(F, run(fn))))


def json_option(fn: F) -> F:
    """--json: print the result as JSON on stdout (the files a command writes are still written)."""
    return click.option(
        "--json",
        "as_json",
        is_flag=True,
        help='Print the result as JSON on stdout (its "kind" and "format" first) instead of the summary.',
    )(fn)


PLOT_FORMATS = ("png", "svg", "pdf")


def plot_format_option(fn: F) -> F:
    """--plot-format png|svg|pdf: the plots' file format."""
    return click.option(
        "--plot-format",
        "plot_format",
        type=click.Choice(PLOT_FORMATS),
        default=None,
        help="The plots' file format (default: the extension of a file -o, else png).",
    )(fn)


def plots_folder_option(help: str) -> Callable[[F], F]:
    """--output-dir DIRECTORY (required; ``help`` says what is written there) and --plot-format: a command
    that writes its result and its plots into a folder; read by :func:`plots_folder_from`."""
    return lambda fn: output_option(folder=True, required=True, help=help)(plot_format_option(fn))


def plots_folder_from(kw: dict[str, Any]) -> tuple[Path, str]:
    """The folder of :func:`plots_folder_option`, made now (:func:`sensorsel.io.files.output_dir`), and the
    plots' format (:func:`plot_format`), popped from ``kw``."""
    fmt = plot_format(kw.pop("plot_format"))
    return output_dir(kw.pop("outdir")), fmt


def plot_format(chosen: str | None, output_file: str | None = None) -> str:
    """The plot format: --plot-format, else the extension of the output file, else png.

    Raises:
        InputError: an output file whose extension is not a plot format, or contradicts --plot-format.
    """
    if output_file is None:
        return chosen or "png"
    ext = Path(output_file).suffix.lower().lstrip(".")
    if ext not in PLOT_FORMATS:
        raise InputError(
            f"-o {output_file}: unsupported plot format {'.' + ext if ext else '(none)'!r}; use .png, .svg or .pdf"
        )
    if chosen is not None and chosen != ext:
        raise InputError(
            f"-o {output_file} is a .{ext} file but --plot-format is {chosen}: give one or make them agree"
        )
    return ext


def not_empty(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    if value is not None and not value.strip():
        raise click.BadParameter("must not be empty (give a file or folder name)", ctx=ctx, param=param)
    return value


def output_option(
    *, folder: bool = False, required: bool = False, help: str = "Write the result as JSON here."
) -> Callable[[F], F]:
    """-o/--output FILE (the argument ``output``), or with ``folder`` --output-dir DIRECTORY (the
    argument ``outdir``: a command that writes several files); an empty name is an error naming the
    option, not a silent no-op."""
    if folder:
        return click.option(
            "--output-dir",
            "outdir",
            required=required,
            callback=not_empty,
            type=click.Path(file_okay=False, dir_okay=True, path_type=str),
            help=help,
        )
    return click.option(
        "-o",
        "--output",
        "output",
        required=required,
        callback=not_empty,
        type=click.Path(dir_okay=False, path_type=str),
        help=help,
    )


def scenario_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """--seq/--kitti-root/--route/--route-format/--up/--forward/--times/--fixture/--name/--landmarks/
    --georef/--osm-classes/--osm-reach/--landmark-seed/--clearance/--rate/--library."""
    opts = [
        click.option(
            "--seq",
            metavar="NN",
            help=(
                "A KITTI odometry sequence (e.g. 03), with --kitti-root or $SENSORSEL_KITTI_ROOT; its pole map is "
                "its landmarks."
            ),
        ),
        path_option(
            "--kitti-root",
            folder=True,
            cls=TopicOption,
            topic="scenario",
            envvar=KITTI_ROOT_ENV,
            show_envvar=True,
            help="KITTI odometry dataset/ folder (poses/NN.txt, sequences/NN/times.txt, optional landmarks/NN.csv).",
        ),
        path_option(
            "--route",
            help=(
                "A route file: KITTI poses, a TUM trajectory, a planar CSV (t,x,y[,heading]) or a GPX track; its "
                "ground plane and forward axis are found from it (docs/scenarios.md)."
            ),
        ),
        click.option(
            "--route-format",
            cls=TopicOption,
            topic="scenario",
            type=click.Choice(list(ROUTE_FORMATS)),
            help="Format of --route (default: csv for a .csv file, else by its first line: 12 numbers kitti, "
            "8 numbers tum, a header csv).",
        ),
        click.option(
            "--up",
            cls=TopicOption,
            topic="scenario",
            metavar="AXIS",
            help="With --route: the world axis that points up (+z, -y, ...), instead of the one "
            "found from the route (the plane of its positions and the axis its rotations turn about).",
        ),
        click.option(
            "--forward",
            cls=TopicOption,
            topic="scenario",
            metavar="AXIS",
            help="With a KITTI or TUM --route: the body axis that points ahead (+x, +z, ...), "
            "instead of the one found along the direction of travel.",
        ),
        path_option(
            "--times",
            cls=TopicOption,
            topic="scenario",
            help="Timestamps of a KITTI --route file (default: 10 Hz, said on stderr).",
        ),
        click.option(
            "--fixture",
            default="suburb",
            show_default=True,
            help="Bundled synthetic scenario used when no route is given.",
        ),
        click.option(
            "--name",
            "scenario_name",
            cls=TopicOption,
            topic="scenario",
            metavar="TEXT",
            help="Name of the scenario (default: the sequence, fixture or route file's name).",
        ),
        click.option(
            "--landmarks",
            metavar="real|synthetic|FILE|osm:FILE",
            multiple=True,
            help=(
                "The landmark map: real (the sequence's pole map), synthetic (generated), a CSV file (x,y in "
                "metres), or osm:FILE (repeatable: an OpenStreetMap extract's landmarks merged with it; "
                "docs/guide-new-city.md). Default: the route's own map, else synthetic."
            ),
        ),
        click.option(
            "--georef",
            cls=TopicOption,
            topic="scenario",
            metavar="LAT,LON,BEARING|utm:ZONE",
            help="Where the route lies, for --landmarks osm:FILE: the latitude, longitude [deg] of its (0, 0) and the "
            "compass bearing [deg, clockwise from north] of its +X axis (a KITTI sequence: the car's heading at "
            "its first frame), or utm:35N when its x, y are UTM easting and northing. A GPX route needs none.",
        ),
        click.option(
            "--osm-classes",
            cls=TopicOption,
            topic="scenario",
            metavar="CLASSES",
            help="With --landmarks osm:FILE: landmark classes, comma-separated, or all (default): street_lamp,"
            "utility_pole,power_pole,flagpole,tree,traffic_signals,stop,give_way,traffic_sign.",
        ),
        osm_reach_option(
            "With --landmarks osm:FILE: the OSM landmarks within this distance of the route (default: 100).",
            cls=TopicOption,
            topic="scenario",
        ),
        click.option(
            "--landmark-seed",
            cls=TopicOption,
            topic="scenario",
            type=int,
            default=0,
            show_default=True,
            help="Seed of the synthetic landmark generator.",
        ),
        click.option(
            "--clearance",
            "clearance_m",
            cls=TopicOption,
            topic="scenario",
            type=click.FloatRange(min=0.0),
            metavar="METRES",
            help="Drop landmarks closer than this to the route (standing on the road). Default: keep them, counted on "
            "stderr; exact duplicates are always merged.",
        ),
        rate_option("the route", cls=TopicOption, topic="scenario"),
        library_option(),
        click.option(
            "--condition",
            "condition_text",
            metavar="CONDITION",
            help=(
                "Operating condition: night, rain_mm_h=MM_PER_H, fog_visibility_m=METRES, snow_mm_h=MM_PER_H, "
                "combined with commas (docs/guide-conditions.md). Default: clear."
            ),
        ),
    ]
    # A command's own option of the same name wins (`landmarks` has its generator's --clearance, the
    # same rule applied while generating): the shared one is then not added, and spec_from leaves
    # its field at the default.
    own = {o for p in getattr(fn, "__click_params__", []) for o in getattr(p, "opts", [])}
    for opt in reversed(opts):
        probe: Any = opt(lambda: None)  # the click.Option the decorator would add, to read its flags
        if not own.intersection(probe.__click_params__[0].opts):
            fn = opt(fn)
    return fn


def path_option(*names: str, folder: bool = False, **extra: Any) -> Callable[[F], F]:
    """An option naming a file (``folder``: a folder) the command reads, or draws into: ``names`` and
    ``extra`` (help, required, ...) as click's, the path given to the command as a string. Outputs:
    :func:`output_option`."""
    path = click.Path(file_okay=False, path_type=str) if folder else click.Path(dir_okay=False, path_type=str)
    return click.option(*names, type=path, **extra)


def library_option() -> Callable[[F], F]:
    """--library FILE (destination ``library_path``): the sensor library YAML."""
    return path_option("--library", "library_path", help="Sensor library YAML (default: the paper's Table I).")


def rate_option(along: str, **extra: Any) -> Callable[[F], F]:
    """--rate HZ (destination ``keyframe_rate_hz``, default 1): keyframes a second along ``along`` (a
    route, or every route of a domain ``sensorsel osm`` writes)."""
    return click.option(
        "--rate",
        "keyframe_rate_hz",
        type=float,
        default=1.0,
        show_default=True,
        metavar="HZ",
        help=f"Keyframe rate along {along} [Hz]: keyframes a second.",
        **extra,
    )


def osm_reach_option(help: str, **extra: Any) -> Callable[[F], F]:
    """--osm-reach METRES (destination ``osm_reach_m``): the OpenStreetMap landmarks within this distance
    of a route; ``extra``: e.g. the default of a command that writes one."""
    return click.option("--osm-reach", "osm_reach_m", type=float, metavar="METRES", help=help, **extra)


def suite_option(name: str = "--suite", *, required: bool = False, help: str) -> Callable[[F], F]:
    """--suite IDS|FILE (or ``name``, e.g. --compare): a suite by sensor ids or a result file naming one
    (read by :func:`sensorsel.cli.common.read_suite`); an empty one is a usage error naming it."""
    return click.option(name, required=required, callback=suite_text, metavar="IDS|FILE", help=help)


def jobs_option(help: str, default: int | None = None) -> Callable[[F], F]:
    """--jobs N: threads or processes on this machine (``help`` says which; results do not depend on
    them); ``default`` None: all cores."""
    shown: dict[str, Any] = (
        {"default": os.cpu_count() or 1, "show_default": "all cores"}
        if default is None
        else {"default": default, "show_default": True}
    )
    return click.option("--jobs", type=click.IntRange(min=1), metavar="N", help=help, **shown)


def spec_from(kw: dict[str, Any]) -> ScenarioSpec:
    """Pop the scenario options out of a command's keyword arguments."""
    given = [f"--{k}" for k in ("seq", "route") if kw.get(k)]
    if len(given) > 1:
        raise click.UsageError(f"give one route: {' or '.join(given)}, not {len(given) == 2 and 'both' or 'several'}")
    if kw.get("route_format") and not kw.get("route"):
        raise click.UsageError(f"--route-format {kw['route_format']} goes with --route FILE")
    for option in ("up", "forward"):
        if kw.get(option) and not kw.get("route"):
            raise click.UsageError(
                f"--{option} {kw[option]} goes with --route FILE (a --seq or fixture is in KITTI's camera frame)"
            )
    if kw.get("times") and not kw.get("route"):
        # a --seq or a fixture reads its own times.txt: a --times here would be silently ignored
        raise click.UsageError(
            f"--times {kw['times']} goes with a KITTI --route FILE; a --seq or fixture has its own times.txt"
        )
    text = kw.pop("condition_text", None)
    condition = parse_condition(text) if text is not None else None
    given_landmarks = kw.pop("landmarks")
    values = (given_landmarks,) if isinstance(given_landmarks, str) else tuple(given_landmarks or ())
    osm = tuple(v[4:] for v in values if v.startswith("osm:"))
    others = [v for v in values if not v.startswith("osm:")]
    if len(others) > 1:
        raise InputError(
            f"--landmarks {' and '.join(others)}: give one landmark map (and any number of osm:FILE extracts "
            "to merge with it)"
        )
    reach = kw.pop("osm_reach_m", None)
    return ScenarioSpec(
        condition=condition if condition is not None and not condition.neutral else None,
        seq=kw.pop("seq"),
        kitti_root=kw.pop("kitti_root"),
        poses=None,
        times=kw.pop("times"),
        fixture=kw.pop("fixture"),
        landmarks=others[0] if others else None,
        landmark_seed=kw.pop("landmark_seed"),
        keyframe_rate_hz=kw.pop("keyframe_rate_hz"),
        route=kw.pop("route"),
        route_format=kw.pop("route_format"),
        clearance_m=kw.pop("clearance_m", None),
        name=kw.pop("scenario_name"),
        up=kw.pop("up", None),
        forward=kw.pop("forward", None),
        georef=kw.pop("georef", None),
        osm=osm,
        osm_classes=kw.pop("osm_classes", None),
        osm_reach_m=DEFAULT_OSM_REACH_M if reach is None else reach,
    )


def problem_from(kw: dict[str, Any]) -> Problem:
    """Load the library and scenario named by the options (pops them from ``kw``); the problem
    records them as its provenance. What was assumed, merged or dropped is said on stderr."""
    spec = spec_from(kw)
    problem = load_problem(spec, kw.pop("library_path"))
    for note in problem.notes:
        click.echo(f"sensorsel: note: {note}", err=True)
    return problem


def target_options(fn: Callable[..., Any] | None = None, *, aggregate: bool = True) -> Any:
    """The scenario options, plus --domain FILE (an operating domain of routes instead of one route)
    and, unless ``aggregate`` is False (a command whose answer no domain score decides),
    --aggregate (how a domain combines its routes' scores). ``@target_options`` or
    ``@target_options(aggregate=False)``."""
    if fn is None:
        return lambda f: target_options(f, aggregate=aggregate)
    if aggregate:
        fn = click.option(
            "--aggregate",
            type=click.Choice(list(AGGREGATES)),
            default=AGGREGATES[0],
            show_default=True,
            metavar="AGGREGATE",
            help="With --domain: normalised = the weighted sum of each route's share of its best, "
            "f_r(S)/f_r(all sensors); raw = the weighted sum of f_r(S) in nats.",
        )(fn)
    fn = click.option(
        "--domain",
        "domain_path",
        type=click.Path(dir_okay=False, path_type=str),
        metavar="FILE",
        help=(
            "An operating-domain YAML file (routes, landmarks, weights; docs/guide-domain.md): one suite for all "
            "its routes, instead of the route options."
        ),
    )(fn)
    return scenario_options(fn)


#: scenario options that choose a route or its landmarks: refused together with --domain
_ROUTE_OPTIONS = (
    "seq",
    "route",
    "times",
    "landmarks",
    "scenario_name",
    "clearance_m",
    "up",
    "forward",
    "condition_text",
    "georef",
    "osm_classes",
    "osm_reach_m",
)


def target_from(kw: dict[str, Any]) -> Target:
    """The problem, or with --domain the domain, named by the options (pops them from ``kw``).

    Raises:
        click.UsageError: --domain together with an option that picks a route or its landmarks.
    """
    path = kw.pop("domain_path", None)
    if path is None:
        return problem_from(kw)
    given = [
        f"--{k.replace('_m', '').replace('scenario_name', 'name').replace('_text', '').replace('_', '-')}"
        for k in _ROUTE_OPTIONS
        if kw.get(k)
    ]
    if given:
        raise click.UsageError(f"--domain {path} lists its own routes and landmarks: drop {', '.join(given)}")
    spec_from(kw)  # consumes the (unused) scenario options
    domain = load_domain(path, kw.pop("library_path"))
    for r in domain.routes:
        for note in r.problem.notes:
            click.echo(f"sensorsel: note: route {r.name}: {note}", err=True)
    return domain


def cluster_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """--scheduler ADDRESS and --workers N: run on a Dask cluster (the ``sensorsel[dask]`` extra).
    Read by :func:`cluster_from`; without either, nothing imports Dask."""
    fn = click.option(
        "--workers",
        "dask_workers",
        type=click.IntRange(min=1),
        default=None,
        metavar="N",
        help="Start a local Dask cluster of N worker processes for this run (the sensorsel[dask] extra).",
    )(fn)
    fn = click.option(
        "--scheduler",
        "dask_scheduler",
        metavar="ADDRESS",
        default=None,
        help="Run on an existing Dask cluster (tcp://HOST:8786); results do not depend on it.",
    )(fn)
    return fn


def resume_option(fn: Callable[..., Any]) -> Callable[..., Any]:
    """--resume: the store's option, declared once for every selecting command (sensorsel.pipeline:
    each task's result is stored under --output-dir, or beside -o FILE, as it finishes, with the
    fingerprint of its inputs)."""
    return click.option(
        "--resume",
        is_flag=True,
        help="Go on from what an interrupted run left under --output-dir or beside -o FILE: stored results "
        "whose inputs match this run are read back; one of other inputs (or damaged) is not: a warning "
        "names the file and what differs, and it is computed again and overwritten. The same answer, timings aside.",
    )(fn)


def cluster_from(kw: dict[str, Any]) -> Any:
    """The :class:`sensorsel.pipeline.cluster.DaskCluster` asked for by --scheduler / --workers (not yet
    started: use it as a context manager), or None (pops the options from ``kw``).

    Raises:
        click.UsageError: both options.
    """
    address, n = kw.pop("dask_scheduler", None), kw.pop("dask_workers", None)
    if address is not None and n is not None:
        raise click.UsageError(
            f"--scheduler {address} uses an existing cluster, --workers {n} starts one: give one of them"
        )
    if address is None and n is None:
        return None
    from sensorsel.pipeline.cluster import DaskCluster  # imports Dask itself only when started

    return DaskCluster(scheduler=address, workers=n, echo=lambda line: click.echo(line, err=True))


def engine_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """--engine and --jobs."""
    from sensorsel.api import ENGINES

    fn = jobs_option(
        "Worker processes owning a domain's routes, or threads for one route's candidates; "
        "require on one long route: processes computing its greedy's marginals ahead "
        "(results do not depend on it)."
    )(fn)
    fn = click.option(
        "--engine",
        type=click.Choice(sorted(ENGINES)),
        default=None,
        help="Scoring engine (default: the fastest; 'reference' rebuilds the GTSAM graph per suite).",
    )(fn)
    return fn


def design_options(fn: Callable[..., Any] | None = None, *, aggregate: bool = True) -> Any:
    """What every design command takes first, in this order: the target (:func:`target_options`,
    with --aggregate unless ``aggregate`` is False), the engine (:func:`engine_options`), the
    cluster (:func:`cluster_options`) and the limits besides the budget (:func:`constraint_options`):
    what :func:`design_from` reads. ``@design_options`` or ``@design_options(aggregate=False)``."""
    if fn is None:
        return lambda f: design_options(f, aggregate=aggregate)
    return target_options(engine_options(cluster_options(constraint_options(fn))), aggregate=aggregate)


def failures_option(help: str, *, default: int = 1, dest: str = "alpha") -> Callable[[F], F]:
    """--failures N (destination ``dest``): how many sensors fail, ``default`` unless given; ``help`` says
    what the command does with them."""
    return click.option(
        "--failures", dest, type=click.IntRange(min=0), default=default, show_default=True, metavar="N", help=help
    )


def force_option(fn: F) -> F:
    """--force: use a result file computed on another problem (or without a fingerprint), with a warning."""
    return click.option(
        "--force",
        is_flag=True,
        help="Use a result file even when it was computed on another library, route, rate, landmark map or "
        "graph settings, or records no fingerprint (a warning on stderr instead of an error).",
    )(fn)


def suite_text(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    """Callback of a --suite/--compare option: an empty suite (``""``, ``","``) is a usage error naming it."""
    if value is not None and not [t for t in value.split(",") if t.strip()]:
        raise click.BadParameter(
            f"names no sensor ({value!r}): give comma-separated sensor ids (see `sensorsel library`)",
            ctx=ctx,
            param=param,
        )
    return value


def constraint_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """--limit RES=VAL (repeatable), --no-slots, --include IDS, --owned, --exclude IDS, --max-sensors N:
    limits besides the budget (:mod:`sensorsel.model.constraints`); read them with :func:`constraints_from`."""
    for deco in reversed(
        [
            click.option(
                "--limit",
                "limits",
                multiple=True,
                metavar="RESOURCE=VALUE",
                help=(
                    "Most the suite may use of a resource the library declares (repeatable): power_w=100 (see "
                    "`sensorsel library`)."
                ),
            ),
            click.option(
                "--no-slots",
                "no_slots",
                is_flag=True,
                default=False,
                help="Ignore the library's mounting slots (at most N sensors of a type at a place).",
            ),
            click.option(
                "--include",
                "include",
                default=None,
                metavar="IDS",
                callback=suite_text,
                help="Sensors every suite must hold (comma-separated ids), e.g. ones already bought.",
            ),
            click.option(
                "--owned",
                is_flag=True,
                default=False,
                help=(
                    "With --include: those sensors are already paid for (their price is not counted against the "
                    "budget)."
                ),
            ),
            click.option(
                "--exclude",
                "exclude",
                default=None,
                metavar="IDS",
                callback=suite_text,
                help="Sensors no suite may hold (comma-separated ids).",
            ),
            click.option(
                "--max-sensors", type=click.IntRange(min=1), default=None, metavar="N", help="Most sensors in a suite."
            ),
        ]
    ):
        fn = deco(fn)
    return fn


def constraints_from(kw: dict[str, Any]) -> Any:
    """The :class:`~sensorsel.model.constraints.Constraints` of :func:`constraint_options` (popped from
    ``kw``); None when none was given (the budget alone, the library's slots honoured)."""
    from sensorsel.model.constraints import Constraints, parse_limit

    limits = [parse_limit(t) for t in kw.pop("limits", ()) or ()]
    no_slots = kw.pop("no_slots", False)
    require, owned = kw.pop("include", None), kw.pop("owned", False)
    exclude, max_sensors = kw.pop("exclude", None), kw.pop("max_sensors", None)
    if owned and not require:
        raise InputError("--owned says the --include sensors are paid for: give --include IDS with it")
    split = lambda t: [x.strip() for x in t.split(",") if x.strip()] if t else []  # noqa: E731
    return Constraints.of(
        limits=limits,
        slots=not no_slots,
        require=split(require),
        owned=owned,
        exclude=split(exclude),
        max_sensors=max_sensors,
    )


def prior_map_option(help: str) -> Callable[[F], F]:
    """--map-sigma METRES alone (destination ``map_sigma``, None unless given): the std [m] of a prior
    map's landmarks; ``help`` says what the command does with it."""
    return click.option("--map-sigma", "map_sigma", type=float, default=None, metavar="METRES", help=help)


def map_sigma_option(fn: F) -> F:
    """--map-sigma METRES: accuracy lines computed localizing in a prior map (default: the SLAM graph);
    with it, --estimate (:func:`estimate_option`): every command that prints an accuracy has both."""
    return estimate_option(
        prior_map_option(
            "Accuracy in a prior map whose landmarks are known to this std [m] (default: in the paper's SLAM "
            "graph, landmarks unknown)."
        )(fn)
    )


def quality_options(fn: F) -> F:
    """How the chosen suite's quality is reported, one group for every command that reports it: its
    accuracy (:func:`map_sigma_option`: --map-sigma and --estimate) and its integrity (the integrity
    options); :func:`design_from` reads them."""
    return map_sigma_option(cast(F, integrity_options(fn)))


def estimate_option(fn: F) -> F:
    """--estimate filter|smoother: the estimate an accuracy is of (default: the filter, as the car drives)."""
    return click.option(
        "--estimate",
        "estimate",
        type=click.Choice(ESTIMATES),
        default="filter",
        show_default=True,
        help=(
            "Accuracy of the filter (as the car drives: at each keyframe from the measurements up to it) or of the "
            "smoother (from the whole route)."
        ),
    )(fn)


def time_limit_option(help: str) -> Callable[[F], F]:
    """--time-limit SECONDS (destination ``time_limit``; None: no limit): stop a search after this long
    with the best found so far; ``help`` says what the command then reports."""
    return click.option(
        "--time-limit",
        "time_limit",
        type=click.FloatRange(min=0, min_open=True),
        default=None,
        metavar="SECONDS",
        help=help,
    )


@dataclass(frozen=True)
class DesignInputs:
    """What the options of a design command say (:func:`design_from`): the target, where the run goes
    (a Dask cluster, not yet started, or None: here), its limits besides the budget, how suites are
    scored, and how the chosen suite's accuracy [m, deg] and integrity are reported (None: a command
    without --map-sigma or the integrity options)."""

    target: Target
    cluster: Any
    constraints: Any
    aggregate: str
    engine: str | None
    jobs: int
    map_sigma: float | None = None
    estimate: str = "filter"
    integrity: Any = None

    def running(self, *bars: Any) -> AbstractContextManager[None]:
        """The cluster started (when one was asked for) and ``bars`` drawn, for a ``with`` block."""
        return running(self.cluster, *bars)

    @property
    def run_options(self) -> dict[str, Any]:
        """The keywords every design run of :mod:`sensorsel.api` takes from these options, under the
        names it gives them: the engine, the threads (``jobs``) and the constraints."""
        return {"engine": self.engine, "jobs": self.jobs, "constraints": self.constraints}

    @property
    def executor(self) -> Any:
        """Where the run's tasks go: the cluster's executor, or None (in this process)."""
        return self.cluster.executor if self.cluster is not None else None

    def with_quality(self, result: Any) -> Any:
        """``result`` with its chosen suite's accuracy and integrity (:func:`sensorsel.api.with_suite_quality`),
        on the target, as --map-sigma, --estimate and the integrity options ask."""
        return with_suite_quality(
            result,
            self.target,
            map_sigma_m=self.map_sigma,
            engine=self.engine,
            estimate=self.estimate,
            integrity=self.integrity,
            jobs=self.jobs,
        )


def design_from(kw: dict[str, Any]) -> DesignInputs:
    """Pops from ``kw`` what the design commands share, in this order: --aggregate (a command without it:
    the default), --engine, --jobs (:func:`design_options`); --map-sigma [m] (checked by
    :func:`check_map_sigma`) and --estimate, and the integrity options, where the command has them; the
    cluster (:func:`cluster_from`), the constraints (:func:`constraints_from`); last the target
    (:func:`target_from`), the one slow step, after every cheap check."""
    aggregate, engine, jobs = kw.pop("aggregate", AGGREGATES[0]), kw.pop("engine"), kw.pop("jobs")
    quality: dict[str, Any] = {}
    if "map_sigma" in kw:
        quality.update(map_sigma=check_map_sigma(kw.pop("map_sigma")), estimate=kw.pop("estimate"))
    if "integrity_risk" in kw:
        quality.update(integrity=integrity_from(kw))
    cluster, constraints = cluster_from(kw), constraints_from(kw)
    return DesignInputs(target_from(kw), cluster, constraints, aggregate, engine, jobs, **quality)


@contextmanager
def running(*contexts: Any) -> Iterator[None]:
    """The cluster started and the progress bars drawn for the ``with`` block (each None: nothing)."""
    with ExitStack() as stack:
        for context in contexts:
            if context is not None:
                stack.enter_context(context)
        yield


@dataclass(frozen=True)
class ResultFile:
    """-o FILE of a run whose state is kept in FILE.checkpoint while it runs (--resume goes on from it):
    the result is written to FILE, then the checkpoint removed."""

    output: str | None
    resume: bool

    @property
    def checkpoint(self) -> Path | None:
        """FILE.checkpoint, or None without -o."""
        return checkpoint_path(self.output) if self.output else None

    def save(self, result: Any, *, unfinished: bool = False) -> Path | None:
        """Write ``result`` to -o FILE (nothing without -o) and remove the checkpoint, unless the
        run stopped ``unfinished`` (at a time limit, its answer not proved): then the checkpoint is
        kept, and --resume goes on from it."""
        if self.output is None or self.checkpoint is None:
            return None
        path = results.save(result, self.output)
        if not unfinished:  # the result is written: the run is no longer interrupted
            self.checkpoint.unlink(missing_ok=True)
        return path


def result_file(output: str | None, resume: bool, kept: str) -> ResultFile:
    """-o FILE and --resume of a run that keeps its state as it runs (``kept``: where, in words); the
    output's folder is checked before anything runs.

    Raises:
        click.UsageError: --resume without -o.
    """
    if resume and not output:
        raise click.UsageError(f"--resume goes on from {kept}: give -o")
    if output:
        output_file(output)
    return ResultFile(output, resume)


def check_map_sigma(value: float | None) -> float | None:
    """``value`` if it is None or a positive finite number of metres, else an InputError naming --map-sigma."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise InputError(f"--map-sigma {value:g}: the landmarks' std must be a positive, finite number of metres")
    return value
