"""The README stays short and true: its two commands are CI's, its tour's output is what the
commands print, its pictures and links exist. The requirements guide's example of an answer on the
bundled route is checked the same way.

The tour's commands run on the bundled route (no KITTI) in a temporary folder; each line the README
shows must appear in the command's output, in order (a line ``...`` stands for lines left out; the
repository's folder is shown as ``...`` and times in seconds are not compared).
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from sensorsel.cli import cli

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text(encoding="utf-8")
MAX_LINES = 200
TIME = re.compile(r"\d+(\.\d+)? s\b")


#: the requirements guide's example of what an answer says (the bundled route: checked as the tour is)
GUIDE = (REPO / "docs" / "guide-requirements.md").read_text(encoding="utf-8")
GUIDE_CHECKED = ("sensorsel require --preset local-streets -q",)


def _blocks(lang: str, text: str = README) -> list[str]:
    return re.findall(r"```" + lang + r"\n(.*?)```", text, flags=re.S)


def _tour(text: str = README) -> list[tuple[str, list[str]]]:
    """(command, expected output lines) of each ``$ sensorsel ...`` in the console blocks of ``text``."""
    out: list[tuple[str, list[str]]] = []
    for block in _blocks("console", text):
        for ln in block.splitlines():
            if ln.startswith("$ "):
                out.append((ln[2:], []))
            elif out:
                out[-1][1].append(ln)
    return out


def test_readme_fits_on_a_few_screens():
    assert len(README.splitlines()) <= MAX_LINES


def test_the_two_commands_come_first_and_ci_runs_the_second():
    first = _blocks("bash")[0].splitlines()
    assert README.index("```bash") < README.index("\n## ")
    assert first[0] == "python3 -m venv .venv && .venv/bin/pip install . && .venv/bin/sensorsel greedy --budget 110000"
    assert first[1] == 'python3 -m venv .venv && .venv/bin/pip install -e ".[test]" && .venv/bin/python -m pytest -q'
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8")
    assert '.venv/bin/pip install -q -e ".[test]" && .venv/bin/python -m pytest -q' in ci


def test_pictures_and_links_exist():
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README):
        if "://" in target:
            continue
        assert (REPO / target).exists(), f"README.md links to {target}, which does not exist"


def _guide() -> list[tuple[str, list[str]]]:
    return [(c, e) for c, e in _tour(GUIDE) if c in GUIDE_CHECKED]


@pytest.mark.parametrize(
    "command,expected",
    _tour() + _guide(),
    ids=[c.split(" -")[0] for c, _ in _tour()] + ["guide-requirements " + c for c, _ in _guide()],
)
def test_tour_prints_what_the_readme_shows(command, expected, tmp_path, monkeypatch):
    argv = shlex.split(command)
    assert argv[0] == "sensorsel"
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(cli, argv[1:])
    assert r.exit_code == 0, r.output
    got = [TIME.sub("<t> s", ln.replace(str(REPO), "...")).rstrip() for ln in r.stdout.splitlines()]
    i = 0
    gap = True  # the shown output may start after some lines (a "..." first) or at the first line
    for want in expected:
        if want.strip() == "...":
            gap = True
            continue
        want = TIME.sub("<t> s", want).rstrip()
        if gap:
            while i < len(got) and got[i] != want:
                i += 1
        assert i < len(got) and got[i] == want, f"`{command}` no longer prints, as the docs show:\n{want}"
        i += 1
        gap = False


def test_facts_the_readme_states_are_the_library_and_the_bundled_route(library, suburb_problem):
    """The numbers outside the tour: the library's size and the bundled route's length and counts."""
    sc = suburb_problem.scenario
    route = sc.route or sc.keyframes
    assert f"{len(library)} placed" in README
    assert f'"suburb": {route.length_m:.0f} m, {sc.n_poses} keyframes, {len(sc.landmarks)} landmarks' in README
    lrl = library[library.parse_suite("LRL-roof")[0]].model.cost_usd
    assert f"${lrl:,.0f} LiDAR" in README


def test_help_texts_name_options_that_exist():
    """Every --option a help text (the group's, a command's, an option's) names is a visible option of some command."""
    visible = {
        o
        for cmd in cli.commands.values()
        for p in cmd.params
        if not getattr(p, "hidden", False)
        for o in getattr(p, "opts", [])
    } | {"--help", "--version"}
    texts = [("sensorsel", cli.help or "")]
    for name, cmd in cli.commands.items():
        texts.append((name, cmd.help or ""))
        texts += [
            (f"{name} {p.opts[0]}", getattr(p, "help", None) or "")
            for p in cmd.params
            if not getattr(p, "hidden", False)
        ]
    for where, text in texts:
        for opt in re.findall(r"(?<![\w-])--[a-z][a-z-]*", text):
            assert opt in visible, f"the help of {where} names {opt}, which no command shows"
    assert "--route" in (cli.help or ""), "the top-level help does not say how to give a route"


def test_the_docs_commands_work_without_an_activated_venv():
    """Every command of the README's bash blocks runs from the venv it makes (.venv/bin/...), so it
    works as written in a fresh shell: a bare `mkdocs` or `pytest` is not on PATH there."""
    for block in _blocks("bash"):
        for line in block.splitlines():
            for cmd in re.split(r"&&|;", line.split("#")[0]):
                words = cmd.split()
                if words and words[0] in ("mkdocs", "pytest", "sensorsel", "pip", "python"):
                    pytest.fail(f"README runs {words[0]!r} from PATH: {line.strip()}")
    assert ".venv/bin/mkdocs build --strict" in README
