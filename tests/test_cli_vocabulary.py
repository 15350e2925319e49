"""One vocabulary of options: every command's options read from the click group and checked against
the table of shared names (sensorsel.cli.vocabulary): the same name means the same thing, with the
same metavar, everywhere; -o is always a file; every command has --json and -q; help pages stay short."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.cli.vocabulary import BY_NAME, RETIRED, VOCABULARY, TopicOption, long_name, markdown_table, problems

DOCS = Path(__file__).resolve().parents[1] / "docs"
#: the group's own help topic takes no result options (like --help and --version)
META = {"help"}


def _options() -> dict[str, list[tuple[str, click.Option, click.Context]]]:
    """Every option of every command, by long name: (command, option, its context)."""
    found: dict[str, list[tuple[str, click.Option, click.Context]]] = defaultdict(list)
    for name, command in sorted(cli.commands.items()):
        ctx = click.Context(command, info_name=name)
        for p in command.params:
            if isinstance(p, click.Option) and p.name != "help":
                found[long_name(p)].append((name, p, ctx))
    return found


OPTIONS = _options()


def test_the_command_line_keeps_the_vocabulary():
    assert problems(cli) == []


def test_the_check_finds_every_kind_of_break():
    """The check itself, on a group that breaks each rule once: it names each break."""
    from sensorsel.cli.options import budget_option, json_option, output_option, quiet_option

    @click.command("a")
    @output_option(folder=True, help="The folder to write.")
    @click.option("--max-seconds", type=float)
    @click.option("--budget", type=float, help="In dollars.")
    @click.option("--jobs", type=int, metavar="N", help="Threads.")
    @click.option("--shared-thing", help="x")
    @json_option
    @quiet_option
    def a(**kw):
        pass

    @click.command("b")
    @click.option("-o", "--output", type=click.Path(file_okay=False), help="A folder.")
    @click.option("--shared-thing", help="x")
    @budget_option()
    def b(**kw):
        pass

    bad = click.Group("bad", commands={"a": a, "b": b})
    found = "\n".join(problems(bad))
    assert "b: no --json" in found and "a: no --json" not in found
    assert "a --max-seconds: a retired name; the concept's name is --time-limit" in found
    assert "a --budget: takes FLOAT, the table says DOLLARS" in found
    assert "a --jobs: its help does not say" in found
    assert "b --output: must be a file" in found
    assert "--shared-thing: taken by a, b but not in the table" in found
    assert "b --budget" not in found and "a --output-dir" not in found


def test_every_name_in_the_table_is_taken_and_every_retired_name_has_its_successor():
    assert {t.name for t in VOCABULARY} <= set(OPTIONS)
    assert set(RETIRED.values()) <= set(BY_NAME) and not set(RETIRED) & set(BY_NAME)


@pytest.mark.parametrize("name", sorted(set(cli.commands) - META))
def test_a_help_page_lists_the_rare_options_on_one_line_and_stays_short(name):
    """A command's --help names its rarely used options (their help is under `sensorsel help TOPIC`),
    lists every other option in full, and is at most 135 lines at 100 columns (it was up to 169)."""
    text = CliRunner().invoke(cli, [name, "--help"], terminal_width=100).output
    assert len(text.splitlines()) <= 135, len(text.splitlines())
    for p in cli.commands[name].params:
        if isinstance(p, click.Option) and not p.hidden:
            assert long_name(p) in text, long_name(p)
            if isinstance(p, TopicOption):
                assert f"sensorsel help {p.topic}" in text
                assert (p.help or "")[:40] not in text


@pytest.mark.parametrize("topic", ["scenario", "integrity"])
def test_a_help_topic_gives_every_rare_option_in_full(topic):
    text = CliRunner().invoke(cli, ["help", topic], terminal_width=100).output
    rare = {
        long_name(p) for uses in OPTIONS.values() for _, p, _ in uses if isinstance(p, TopicOption) and p.topic == topic
    }
    assert rare
    for name in rare:
        assert name in text


def test_the_cli_reference_shows_the_table():
    assert markdown_table() in (DOCS / "cli.md").read_text()
    text = CliRunner().invoke(cli, ["help", "options"]).output
    for t in VOCABULARY:
        assert f"{t.name} {t.metavar}".strip() in text and t.meaning in text


def test_a_retired_name_is_refused_naming_it(tmp_path):
    r = CliRunner().invoke(cli, ["pareto", "--fixture", "tiny", "-o", str(tmp_path / "p")])
    assert r.exit_code == 2 and "-o" in r.output
    r = CliRunner().invoke(cli, ["require", "--fixture", "tiny", "--preset", "freeway", "--aggregate", "raw"])
    assert r.exit_code == 2 and "--aggregate" in r.output


def test_json_of_a_command_that_writes_a_file_says_what_it_wrote(tmp_path):
    import json

    r = CliRunner().invoke(cli, ["landmarks", "--fixture", "tiny", "-o", str(tmp_path / "lm.csv"), "--json"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    rows = (tmp_path / "lm.csv").read_text().splitlines()
    assert data["kind"] == "landmarks" and data["format"] == 1 and data["file"] == str(tmp_path / "lm.csv")
    assert data["landmarks"] == len(rows) - 1  # a header, then one landmark a line
    r = CliRunner().invoke(
        cli, ["scene", "--fixture", "tiny", "-o", str(tmp_path / "s.svg"), "--suite", "LRL-roof", "--json"]
    )
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["kind"] == "scene" and data["suite"] == ["LRL-roof"] and (tmp_path / "s.svg").is_file()


def test_osm_json_says_the_domain_it_wrote(tmp_path):
    import json

    import yaml

    r = CliRunner().invoke(cli, ["osm", "--sample", "helsinki", "--output-dir", str(tmp_path / "city"), "--json"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    written = yaml.safe_load((tmp_path / "city" / "domain.yaml").read_text())
    assert data["kind"] == "osm" and data["domain"] == str(tmp_path / "city" / "domain.yaml")
    assert data["routes"] == len(written["routes"])
    text = (
        CliRunner().invoke(cli, ["osm", "--sample", "helsinki", "--output-dir", str(tmp_path / "again"), "-q"]).stdout
    )
    rows = {line.split()[0]: int(line.split()[1]) for line in text.splitlines()[2:] if len(line.split()) == 3}
    assert {c: v["count"] for c, v in data["landmarks"].items()} == rows  # the summary's table, as JSON


def test_the_table_is_read_row_by_row():
    """The table's text: a short name, a narrower metavar, a flag, an empty gist and a meaning that goes
    on over two lines, each read into its term; a misspelt section heading is refused, not a new section."""
    from sensorsel.cli.vocabulary import OUTPUT, SUITE, Term, _terms

    text = (
        "Output:\n-o/--output FILE |  | the file\n    written\n--json | json | print it\n"
        "Suite and constraints:\n--suite IDS|FILE (FILE) | sensor ids | a suite\n"
    )
    assert _terms(text) == (
        Term("--output", "FILE", "", "the file written", OUTPUT, short="-o"),
        Term("--json", "", "json", "print it", OUTPUT),
        Term("--suite", "IDS|FILE", "sensor ids", "a suite", SUITE, narrower="FILE"),
    )
    with pytest.raises(ValueError, match="'Outptu' is not a help section"):
        _terms("Outptu:\n--json | json | print it\n")
