"""The documentation site builds warning-free in strict mode, with every command in its CLI reference.

The build is MkDocs (mkdocs.yml, pages under docs/) with mkdocs-click rendering the click commands and
mkdocstrings the docstrings; the tools come with the test extra (``sensorsel[docs]``). Strictness is
tested too: a copy of the site with one broken link, or with a page the nav does not list, must fail.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]


def _build(config: Path, site: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(config), "-d", str(site)],
        capture_output=True,
        text=True,
        cwd=REPO,
        env=env,
        timeout=300,
    )


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    p = _build(REPO / "mkdocs.yml", out)
    assert p.returncode == 0, "the documentation site does not build in strict mode:\n" + p.stdout + p.stderr
    assert "WARNING" not in p.stderr, p.stderr
    return out


def test_site_builds_with_every_page_of_the_nav(site):
    nav = yaml.safe_load((REPO / "mkdocs.yml").read_text(encoding="utf-8"))["nav"]

    def pages(items):
        for it in items:
            for v in it.values() if isinstance(it, dict) else [it]:
                yield from (pages(v) if isinstance(v, list) else [v])

    listed = list(pages(nav))
    assert "cli.md" in listed and "api.md" in listed
    for page in listed:
        html = site / ("index.html" if page == "index.md" else Path(page).with_suffix("") / "index.html")
        assert html.is_file(), f"{page} is in the nav but was not built"


def test_every_command_is_in_the_cli_reference_with_its_help(site):
    from sensorsel.cli import cli

    html = (site / "cli" / "index.html").read_text(encoding="utf-8")
    assert cli.commands, "no commands"
    for name, cmd in cli.commands.items():
        if cmd.hidden:
            continue
        assert (cmd.help or "").strip() and (cmd.get_short_help_str() or "").strip(), (
            f"sensorsel {name} has no help text"
        )
        assert f'id="sensorsel-{name}"' in html, f"sensorsel {name} is missing from the rendered CLI reference"
        for opt in cmd.params:
            for flag in getattr(opt, "opts", []):
                if flag.startswith("--") and not getattr(opt, "hidden", False):
                    assert flag in html, f"sensorsel {name} {flag} is missing from the rendered CLI reference"


def test_api_reference_is_rendered_from_the_docstrings(site):
    import inspect

    import sensorsel.api as api

    html = (site / "api" / "index.html").read_text(encoding="utf-8")
    functions = [
        n
        for n, f in inspect.getmembers(api, inspect.isfunction)
        if f.__module__ == "sensorsel.api" and not n.startswith("_")
    ]
    assert "run_greedy" in functions
    for name in functions:
        assert f'id="sensorsel.api.{name}"' in html, f"sensorsel.api.{name} is missing from the API reference"


def _stub_site_sources(tmp: Path) -> dict:
    """The project's mkdocs.yml (its strictness and validation settings, its nav) over stub pages:
    one heading a page the nav lists. Building it proves what the settings refuse, in seconds (the
    real pages are built by the `site` fixture)."""
    cfg = yaml.safe_load((REPO / "mkdocs.yml").read_text(encoding="utf-8"))
    docs = tmp / "docs"

    def pages(items):
        for it in items:
            for v in it.values() if isinstance(it, dict) else [it]:
                yield from (pages(v) if isinstance(v, list) else [v])

    for page in pages(cfg["nav"]):
        (docs / page).parent.mkdir(parents=True, exist_ok=True)
        (docs / page).write_text(f"# {page}\n", encoding="utf-8")
    cfg["docs_dir"] = str(docs)
    cfg["plugins"][1]["mkdocstrings"]["handlers"]["python"]["paths"] = [str(REPO / "src")]
    return cfg


@pytest.mark.parametrize("breakage", ["nothing", "broken link", "page not in the nav", "nav entry without its page"])
def test_strict_build_fails_on_a_broken_site(tmp_path, breakage):
    cfg = _stub_site_sources(tmp_path)
    page = tmp_path / "docs" / "guide-extra.md"
    if breakage == "broken link":
        page.write_text("# Extra\n\nSee [the missing page](guide-missing.md).\n", encoding="utf-8")
        cfg["nav"].append({"Extra": "guide-extra.md"})
    elif breakage == "page not in the nav":
        page.write_text("# Extra\n\nA page nobody listed.\n", encoding="utf-8")
    elif breakage == "nav entry without its page":
        cfg["nav"].append({"Extra": "guide-extra.md"})
    config = tmp_path / "mkdocs.yml"
    config.write_text(yaml.safe_dump(cfg, sort_keys=False), encoding="utf-8")
    p = _build(config, tmp_path / "site")
    if breakage == "nothing":  # the stub site itself builds: what fails below is the breakage
        assert p.returncode == 0 and "WARNING" not in p.stderr, p.stderr
        return
    assert p.returncode != 0, f"a site with a {breakage} built in strict mode:\n{p.stderr}"
    assert "guide-" in p.stderr, p.stderr


def _cli_reference_entries(site: Path) -> dict[str, dict[str, str]]:
    """command -> first flag -> its entry in the built CLI reference (the text, wrapped lines joined)."""
    import html as html_lib
    import re

    raw = (site / "cli" / "index.html").read_text(encoding="utf-8")
    out: dict[str, dict[str, str]] = {}
    for part in raw.split('id="sensorsel-')[1:]:
        name = part[: part.index('"')]
        text = html_lib.unescape(re.sub(r"<[^>]+>", "", part))
        entries: dict[str, str] = {}
        key = None
        for line in text.splitlines():
            if re.match(r"^  -", line):
                key = line.split()[0].rstrip(",")
                entries[key] = line.strip()
            elif key is not None and line.startswith("   "):
                entries[key] += " " + line.strip()
            else:
                key = None
        out[name] = entries
    return out


def test_the_cli_reference_tells_defaults_required_options_and_choices_as_they_are(site):
    """What the built reference says of each option is true of the command: no "Sentinel.UNSET" for a
    default, every required option marked, every choice listed, a default that depends on the machine
    said in words (never the build machine's number), the shown defaults the command's own."""
    import click

    from sensorsel.cli import cli

    html = (site / "cli" / "index.html").read_text(encoding="utf-8")
    assert "Sentinel" not in html and "UNSET" not in html
    entries = _cli_reference_entries(site)
    checked = {"required": 0, "choices": 0, "defaults": 0}
    for name, cmd in cli.commands.items():
        for opt in cmd.params:
            if not isinstance(opt, click.Option) or opt.hidden:
                continue
            entry = " ".join(entries[name][flag] for flag in opt.opts if flag in entries[name])
            assert entry, f"sensorsel {name} {opt.opts[0]} has no entry in the CLI reference"
            if opt.required:
                assert "required" in entry, (
                    f"sensorsel {name} {opt.opts[0]} is required; the reference does not say so: {entry}"
                )
                checked["required"] += 1
            if isinstance(opt.type, click.Choice) and opt.metavar is None:
                missing = [c for c in opt.type.choices if str(c) not in entry]
                assert not missing, f"sensorsel {name} {opt.opts[0]}: choices {missing} not listed: {entry}"
                checked["choices"] += 1
            if isinstance(opt.show_default, str):
                assert f"default: {opt.show_default}" in entry.replace("(", "").replace(")", ""), entry
            elif opt.show_default and not opt.is_flag and opt.default is not None and not callable(opt.default):
                shown = opt.default if not isinstance(opt.default, (list, tuple)) else ", ".join(map(str, opt.default))
                assert f"default: {shown}" in entry, f"sensorsel {name} {opt.opts[0]} default {opt.default!r}: {entry}"
                checked["defaults"] += 1
    assert "all cores" in entries["greedy"]["--jobs"]
    assert all(n > 0 for n in checked.values()), checked


def _command_table(path: Path) -> list[tuple[str, str]]:
    """(question, command) of each row of the page's table headed "| the question | the command"."""
    lines = path.read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| the question | the command"))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split(" | ")]
        rows.append((cells[0], cells[1]))
    return rows


def test_the_home_page_and_the_readme_list_the_same_commands():
    import re

    from sensorsel.cli import cli

    readme, home = _command_table(REPO / "README.md"), _command_table(REPO / "docs" / "index.md")
    assert home == readme
    named = set(re.findall(r"`sensorsel (\w+)", " ".join(c for _, c in readme)))
    assert named <= set(cli.commands), named - set(cli.commands)
    assert {"greedy", "require", "pareto", "robust", "simulate", "osm", "study", "kitti"} <= named


def test_user_pages_name_no_internal_issue_numbers():
    import re

    pages = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
    found = [
        f"{p.name}:{n}: {m.group(0)}"
        for p in pages
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        for m in re.finditer(r"\b[Ii]ssues? #?\d+", line)
    ]
    assert not found, found


def test_the_bundled_route_has_one_length_everywhere(suburb_problem):
    import re

    length = round(suburb_problem.scenario.route.length_m)
    said = {
        p.name: int(m.group(1))
        for p in (REPO / "README.md", REPO / "docs" / "getting-started.md", REPO / "docs" / "guide-data.md")
        for m in re.finditer(r'"suburb": (\d+) m', p.read_text(encoding="utf-8"))
    }
    assert len(said) == 3 and set(said.values()) == {length}, (said, length)


def test_user_pages_point_at_no_folder_of_the_build_machine():
    """A user has no ../shared nor /work: the pages name the folder `sensorsel kitti` builds."""
    pages = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
    found = [
        f"{p.name}:{n}"
        for p in pages
        if p.name != "development.md"
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if "shared/" in line or "/work/" in line
    ]
    assert not found, found
