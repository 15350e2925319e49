"""One table of the option names the commands share, and the help layout built on it.

Every option that two commands take, or that names a concept the commands share (an output, a
suite, a limit of time, a plot), is a :class:`Term` of :data:`VOCABULARY`: one name, one metavar, one
meaning. ``tests/test_cli_vocabulary.py`` walks the click group and checks every command's options
against it; ``docs/cli.md`` shows it (:func:`markdown_table`); ``sensorsel help options`` prints it.

The help of a command (:class:`Command`) lists its own options first, then the shared ones in the
sections of this table. The options a person rarely needs (a route's axes and format, the OSM merge,
the integrity model's limits) are listed once, under ``sensorsel help scenario`` and ``sensorsel help
integrity``: a command's ``--help`` names them on one line.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from typing import Any

import click


@dataclass(frozen=True)
class Term:
    """One shared option: its long name, short name, metavar as ``--help`` shows it (``""`` for a
    flag), the words every command's help for it contains (its meaning, in short), the sentence the
    table gives, and the help section it is listed in."""

    name: str
    metavar: str
    gist: str
    meaning: str
    section: str
    short: str = ""
    narrower: str = ""  # the metavar of a command that takes only some of the forms (certify --suite FILE)


SCENARIO, SUITE, SPEC, ACCURACY, RUNNING, OUTPUT = (
    "Scenario",
    "Suite and constraints",
    "Specification",
    "Accuracy and integrity",
    "Running",
    "Output",
)
#: the help sections, in the order a command's help lists them (its own options come first)
SECTIONS = (SCENARIO, SUITE, SPEC, ACCURACY, RUNNING, OUTPUT)

#: the rarely used options' help topics (``sensorsel help TOPIC``), and what each holds
TOPICS = {
    "scenario": "the options that say how to read a route and its landmarks: a route file's format and axes, "
    "its timestamps, KITTI's folder, the synthetic landmarks, the OpenStreetMap merge",
    "integrity": "the integrity model: the risk per hour, the alert limits, the associator's gate, the lever",
}

#: The table, one option a line under its section's heading (a line ending in ``:``): ``NAME METAVAR |
#: GIST | MEANING``: ``-o/--output`` names the short name too; ``IDS|FILE (FILE)`` gives after the metavar
#: the narrower one of a command that takes only some of the forms (certify --suite FILE); no metavar: a
#: flag; an empty gist: none. A line that starts with spaces goes on with the meaning of the line above.
_TABLE = """
Scenario:
--seq NN | kitti | a KITTI odometry sequence
--kitti-root DIRECTORY | kitti | KITTI's dataset/ folder ($SENSORSEL_KITTI_ROOT)
--route FILE | route | a route file (KITTI poses, TUM, CSV, GPX)
--route-format [kitti|tum|csv] | format | the format of --route
--up AXIS | up | the world axis that points up in --route
--forward AXIS | ahead | the body axis that points ahead in --route
--times FILE | timestamps | timestamps of a KITTI --route
--fixture TEXT | bundled | a bundled synthetic route (default suburb)
--name TEXT | name | the scenario's name
--landmarks real|synthetic|FILE|osm:FILE | landmarks | the landmark map
--georef LAT,LON,BEARING|utm:ZONE | compass bearing | where a route's frame lies on Earth
--osm-classes CLASSES | landmark classes | which OpenStreetMap landmark classes
--osm-reach METRES | within this distance of the route | OpenStreetMap landmarks within this distance of a route
--landmark-seed INTEGER | seed | seed of the synthetic landmarks
--clearance METRES | closer than this to the route | drop landmarks closer than this to the route
--rate HZ | keyframe | keyframes a second along a route
--library FILE | sensor library | the sensor library YAML (default: the paper's Table I)
--condition CONDITION | condition | night, rain, fog or snow
--domain FILE | domain | an operating domain: many routes, one suite
--aggregate AGGREGATE | domain | how a domain combines its routes' scores
Suite and constraints:
--budget DOLLARS | dollars | a budget in dollars (110000, 110,000, $110,000)
--suite IDS|FILE (FILE) | sensor ids | a suite: comma-separated sensor ids, or a result file that names one
    (certify: a greedy result file)
--compare IDS|FILE | suite | a second suite drawn beside the first (same forms as --suite)
--rule [uniform|cost-benefit|marginal|best-of] | rule | the greedy rule
--rules RULES | rules | several greedy rules, comma-separated
--lazy | lazy | lazy (Minoux) greedy evaluation: same picks, fewer evaluations
--failures N | fail | how many sensors may fail
--limit RESOURCE=VALUE | resource | most a suite may use of a resource (power_w=100)
--no-slots | mounting slots | ignore the library's mounting slots
--include IDS | every suite must hold | sensors every suite must hold
--owned | paid for | the --include sensors are already paid for
--exclude IDS | no suite may hold | sensors no suite may hold
--max-sensors N | most sensors | most sensors in a suite
--force | result file | use a result file computed on another problem (a warning, not an error)
Specification:
--preset local-streets|freeway | published | a published accuracy specification
--lateral METRES | lateral | bound on the lateral error [m]
--longitudinal METRES | longitudinal | bound on the longitudinal error [m]
--heading DEGREES | heading | bound on the heading error [deg]
--sigma | 1σ | the bounds are 1σ, not 95 %
--at PERCENT | keyframes | share of keyframes that must meet the bounds
--spec FILE | specification file | a specification file (per-route specifications)
Accuracy and integrity:
--map-sigma METRES | prior map | localize in a prior map whose landmarks are known to this std [m]
--estimate [filter|smoother] | filter | accuracy of the filter (as the car drives) or the smoother
--integrity-risk P | per hour | allowed probability per hour of an error beyond an alert limit
--alert-lateral METRES | alert limit | lateral alert limit [m]
--alert-longitudinal METRES | alert limit | longitudinal alert limit [m]
--alert-heading DEGREES | alert limit | heading alert limit [deg]
--gate-probability P | gate | the associator's chi-square gate probability
--max-association-risk P | wrong association | leave out measurements likelier than P to be misassociated
Running:
--engine [fast|reference] | engine | the scoring engine
--jobs N | results do not depend on it | threads or processes on this machine
--workers N | dask | start a local Dask cluster of N workers
--scheduler ADDRESS | dask | run on an existing Dask cluster
--time-limit SECONDS | stop | stop a search after this long with the best found so far
--resume | interrupted run | go on from what an interrupted run left
Output:
-o/--output FILE |  | the file the result is written to (JSON; an image for scene, CSV for landmarks)
--output-dir DIRECTORY | folder | the folder a command that writes several files writes them to
--plot FILE | draw | draw the result's plot into this file (png, svg or pdf by its extension)
--plot-format [png|svg|pdf] | plot | the format of the plots written to --output-dir or -o
--json | json | print the result as JSON on stdout
-q/--quiet | no progress | no progress on stderr
--progress | progress | progress on stderr even with -q ($SENSORSEL_PROGRESS)
"""


def _terms(text: str) -> tuple[Term, ...]:
    """The :class:`Term` of each row of :data:`_TABLE`, in its order."""
    rows: list[tuple[str, list[str]]] = []
    section = ""
    for line in text.strip("\n").splitlines():
        if line.startswith(" "):
            rows[-1][1][-1] += " " + line.strip()
        elif line.endswith(":") and " | " not in line:
            section = line[:-1]
            if section not in SECTIONS:
                raise ValueError(f"vocabulary: {section!r} is not a help section ({', '.join(SECTIONS)})")
        else:
            rows.append((section, [f.strip() for f in line.split(" | ")]))
    terms = []
    for section, (left, gist, meaning) in rows:
        names, _, metavar = left.partition(" ")
        short, _, name = names.rpartition("/")
        metavar, _, narrower = metavar.partition(" (")
        terms.append(Term(name, metavar, gist, meaning, section, short=short, narrower=narrower.rstrip(")")))
    return tuple(terms)


VOCABULARY: tuple[Term, ...] = _terms(_TABLE)

BY_NAME = {t.name: t for t in VOCABULARY}

#: names no command takes any more: the one above is the concept's name
RETIRED = {
    "--max-seconds": "--time-limit",
    "--reach": "--osm-reach",
    "--keyframe-rate": "--rate",
    "--result": "--suite",
    "--format": "--plot-format",
    "--require": "--include",
    "--outdir": "--output-dir",
}


class TopicOption(click.Option):
    """A shared option a command takes but lists only on one line of its help; its full help is in
    ``sensorsel help TOPIC``."""

    def __init__(self, *args: Any, topic: str, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.topic = topic


def long_name(param: click.Parameter) -> str:
    """An option's long name (``--output`` of ``-o/--output``); an argument's name."""
    names = [o for o in param.opts if o.startswith("--")]
    return names[0] if names else param.name or ""


def section_of(param: click.Parameter) -> str | None:
    """The help section a shared option is listed in; None for a command's own option."""
    term = BY_NAME.get(long_name(param))
    return term.section if term is not None else None


class Command(click.Command):
    """A command whose help lists its own options, then the shared ones by section (:data:`SECTIONS`),
    with the rarely used ones (:class:`TopicOption`) named on one line per topic."""

    def format_options(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        own: list[tuple[str, str]] = []
        by_section: dict[str, list[tuple[str, str]]] = {s: [] for s in SECTIONS}
        rare: dict[str, list[str]] = {}
        for param in self.get_params(ctx):
            record = param.get_help_record(ctx)
            if record is None:
                continue
            if isinstance(param, TopicOption):
                rare.setdefault(param.topic, []).append(long_name(param))
                continue
            section = section_of(param)
            (by_section[section] if section is not None else own).append(record)
        if own:
            with formatter.section("Options"):
                formatter.write_dl(own)
        for section in SECTIONS:
            if by_section[section]:
                with formatter.section(section):
                    formatter.write_dl(by_section[section])
        if rare:
            # written by hand: click's wrapping would break an option's name at its hyphen
            width = max(40, (formatter.width or 80) - formatter.current_indent - 4)
            with formatter.section("More options (their help: sensorsel help TOPIC)"):
                for topic, names in rare.items():
                    lines = textwrap.wrap(" ".join(names), width, break_on_hyphens=False, break_long_words=False)
                    formatter.write_text(f"sensorsel help {topic}:")
                    with formatter.indentation():
                        for line in lines:
                            formatter.write(f"{'':>{formatter.current_indent}}{line}\n")


def problems(group: click.Group, exempt: frozenset[str] = frozenset({"help"})) -> list[str]:
    """What in ``group``'s commands breaks the vocabulary, one line each (empty: none): an option two
    commands share that the table lacks; a shared name with another metavar, short name or meaning
    (its help lacks the term's gist); a retired name; an -o that is not a file or an --output-dir
    that is not a folder; a command (but ``exempt``) without --json or -q."""
    out: list[str] = []
    users: dict[str, set[str]] = {}
    for cname, command in sorted(group.commands.items()):
        ctx = click.Context(command, info_name=cname)
        opts = {o for p in command.params for o in p.opts}
        if cname not in exempt and not {"--json", "-q", "--quiet"} <= opts:
            out.append(f"{cname}: no --json or no -q/--quiet")
        for p in command.params:
            if not isinstance(p, click.Option) or p.name == "help":
                continue
            name = long_name(p)
            users.setdefault(name, set()).add(cname)
            for o in (*p.opts, *p.secondary_opts):
                if o in RETIRED:
                    out.append(f"{cname} {o}: a retired name; the concept's name is {RETIRED[o]}")
            term = BY_NAME.get(name)
            if term is None:
                continue
            shown = "" if p.is_flag else p.make_metavar(ctx)
            if shown not in {term.metavar, term.narrower} - {""} and not (p.is_flag and not term.metavar):
                out.append(f"{cname} {name}: takes {shown or 'a flag'}, the table says {term.metavar or 'a flag'}")
            shorts = [o for o in p.opts if not o.startswith("--")]
            if shorts != ([term.short] if term.short else []):
                out.append(f"{cname} {name}: short name {shorts}, the table says {term.short or 'none'}")
            if term.gist.lower() not in (p.help or "").lower():
                out.append(f"{cname} {name}: its help does not say {term.gist!r} ({term.meaning})")
            folder = {"--output": False, "--output-dir": True}.get(name)
            if folder is not None and not (
                isinstance(p.type, click.Path) and p.type.dir_okay == folder and p.type.file_okay != folder
            ):
                out.append(f"{cname} {name}: must be a {'folder' if folder else 'file'}")
    for name, cnames in sorted(users.items()):
        if len(cnames) > 1 and name not in BY_NAME:
            out.append(f"{name}: taken by {', '.join(sorted(cnames))} but not in the table")
    return out


def markdown_table() -> str:
    """The vocabulary as a Markdown table (docs/cli.md shows it; a test keeps the two the same)."""
    rows = ["| option | takes | meaning | help section |", "|---|---|---|---|"]
    for t in VOCABULARY:
        name = f"`{t.short}/{t.name}`" if t.short else f"`{t.name}`"
        takes = f"`{t.metavar}`".replace("|", "\\|") if t.metavar else "a flag"
        rows.append(f"| {name} | {takes} | {t.meaning} | {t.section} |")
    return "\n".join(rows) + "\n"


def plain_table() -> str:
    """The vocabulary for a terminal: by section, each option, what it takes and what it means."""
    lines: list[str] = []
    width = max(len(f"{t.short}/{t.name}" if t.short else t.name) + 1 + len(t.metavar) for t in VOCABULARY)
    for section in SECTIONS:
        lines.append(f"{section}:")
        for t in (t for t in VOCABULARY if t.section == section):
            left = (f"{t.short}/{t.name}" if t.short else t.name) + (f" {t.metavar}" if t.metavar else "")
            lines.append(f"  {left:<{width}}  {t.meaning}")
    return "\n".join(lines) + "\n"


@click.command("help", cls=Command, short_help="The options every command shares (options), or a topic's options.")
@click.argument("topic", required=False, type=click.Choice(["options", *TOPICS]), default="options")
@click.pass_context
def help_cmd(ctx: click.Context, topic: str) -> None:
    """The table of options every command shares (TOPIC options, the default), or the full help of
    the rarely used options a command's --help names on one line: scenario (how a route and its
    landmarks are read) or integrity (the integrity model)."""
    if topic == "options":
        click.echo(plain_table(), nl=False)
        return
    group = ctx.find_root().command
    seen: dict[str, tuple[str, str]] = {}
    for name in sorted(getattr(group, "commands", {})):
        command = group.commands[name]  # type: ignore[attr-defined]
        sub = click.Context(command, info_name=name, parent=ctx.find_root())
        for param in command.get_params(sub):
            if isinstance(param, TopicOption) and param.topic == topic and long_name(param) not in seen:
                record = param.get_help_record(sub)
                if record is not None:
                    seen[long_name(param)] = record
    formatter = ctx.make_formatter()
    formatter.write_text(
        f"The {topic} options ({TOPICS[topic]}); every command that takes them takes them the same way."
    )
    with formatter.section(f"{topic.capitalize()} options"):
        formatter.write_dl(list(seen.values()))
    click.echo(formatter.getvalue(), nl=False)


COMMANDS = [help_cmd]
