"""Output files: written atomically, and a place that cannot be written is one clear error, found before the run."""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner

from sensorsel.cli import cli
from sensorsel.errors import OutputError
from sensorsel.io.files import atomic_write_text, output_dir, output_file


def _fails_before_work(*args: str) -> str:
    """Exit 2 with one line naming the output path, and without the scenario even being loaded."""
    result = CliRunner().invoke(cli, list(args))
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    err = result.stderr.strip()
    assert len(err.splitlines()) == 1 and err.startswith("sensorsel: error: "), err
    assert "cannot write" in err
    # the scenario summary is printed only after a run; nothing of it may appear
    assert "keyframes" not in result.stdout
    return err


def test_atomic_write_replaces_whole_file_and_leaves_no_temporary(tmp_path: Path):
    target = tmp_path / "sub" / "out.json"
    atomic_write_text(target, "first")
    atomic_write_text(target, "second")
    assert target.read_text() == "second"
    assert sorted(p.name for p in target.parent.iterdir()) == ["out.json"]


@contextlib.contextmanager
def _umask(mask: int) -> Iterator[None]:
    """The process's umask set to ``mask`` for the block (restored after it)."""
    old = os.umask(mask)
    try:
        yield
    finally:
        os.umask(old)


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


@pytest.mark.skipif(os.name != "posix", reason="permission bits and the umask are POSIX's")
@pytest.mark.parametrize("mask", [0o022, 0o002, 0o077], ids=lambda m: f"umask-{m:03o}")
def test_a_new_result_gets_the_permissions_open_would_give_it(tmp_path: Path, mask: int):
    # what open(path, "w") gives a new file: read-write for all less the umask (a temporary file's
    # 0o600 would leave a result shared with a group unreadable to it)
    with _umask(mask):
        out = atomic_write_text(tmp_path / f"new-{mask:o}.json", "data")
        with open(tmp_path / f"by-open-{mask:o}.json", "w") as fh:
            fh.write("data")
    assert _mode(out) == 0o666 & ~mask == _mode(tmp_path / f"by-open-{mask:o}.json")


@pytest.mark.skipif(os.name != "posix", reason="permission bits and the umask are POSIX's")
def test_a_result_written_again_keeps_its_permissions(tmp_path: Path):
    target = tmp_path / "out.json"
    target.write_text("first")
    with _umask(0o022):
        for mode in (0o600, 0o664, 0o640):
            target.chmod(mode)
            atomic_write_text(target, f"again {mode:o}")
            assert _mode(target) == mode and target.read_text() == f"again {mode:o}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]


@pytest.mark.skipif(os.name != "posix", reason="permission bits and the umask are POSIX's")
def test_the_commands_results_and_plots_are_readable_by_the_group_and_others(tmp_path: Path):
    result, plot = tmp_path / "greedy.json", tmp_path / "scene.png"
    with _umask(0o022):
        for args in (["greedy", "--budget", "5000", "-q", "-o", str(result)], ["scene", "-o", str(plot)]):
            got = CliRunner().invoke(cli, args)
            assert got.exit_code == 0, got.output
    assert _mode(result) == _mode(plot) == 0o644


def test_write_into_a_file_as_folder_names_the_path(tmp_path: Path):
    blocker = tmp_path / "blocker"
    blocker.write_text("x")
    with pytest.raises(OutputError) as exc:
        atomic_write_text(blocker / "out.json", "data")
    assert str(blocker / "out.json") in str(exc.value)
    assert blocker.read_text() == "x"


def test_output_to_an_existing_folder_is_refused(tmp_path: Path):
    with pytest.raises(OutputError, match="is a folder"):
        atomic_write_text(tmp_path, "data")
    with pytest.raises(OutputError, match="is a folder"):
        output_file(tmp_path)


def test_output_dir_refuses_a_file_and_creates_parents(tmp_path: Path):
    f = tmp_path / "f"
    f.write_text("x")
    with pytest.raises(OutputError, match="not a folder"):
        output_dir(f)
    made = output_dir(tmp_path / "a" / "b")
    assert made.is_dir()


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc, where nothing can be created")
def test_a_folder_the_system_refuses_is_an_output_error():
    # /proc refuses new entries even to root, so this holds whoever runs the tests
    with pytest.raises(OutputError, match="/proc/sensorsel-test/out.json: cannot write"):
        output_file("/proc/sensorsel-test/out.json")
    with pytest.raises(OutputError, match="/proc/sensorsel-test.json: cannot write"):
        atomic_write_text("/proc/sensorsel-test.json", "data")


def test_commands_refuse_an_unwritable_output_before_running(tmp_path: Path):
    blocker = tmp_path / "blocker"
    blocker.write_text("x")
    bad = str(blocker / "out")
    assert bad in _fails_before_work("greedy", "--fixture", "tiny", "--budget", "5000", "-o", bad + ".json")
    assert bad in _fails_before_work("pareto", "--fixture", "tiny", "--output-dir", bad)
    assert bad in _fails_before_work("resilient", "--fixture", "tiny", "--budget", "5000", "--output-dir", bad)
    assert bad in _fails_before_work(
        "simulate", "--fixture", "tiny", "--suite", "LRL-roof", "--runs", "1", "--output-dir", bad
    )
    assert bad in _fails_before_work("certify", "--fixture", "tiny", "--budget", "5000", "-o", bad + ".json")
    assert bad in _fails_before_work("optimal", "--fixture", "tiny", "--budget", "5000", "-o", bad + ".json")
    assert blocker.read_text() == "x"


def test_scene_into_a_missing_place_is_one_clear_error(tmp_path: Path):
    blocker = tmp_path / "blocker"
    blocker.write_text("x")
    result = CliRunner().invoke(cli, ["scene", "--fixture", "tiny", "-o", str(blocker / "scene.png")])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert str(blocker / "scene.png") in result.stderr and "cannot write" in result.stderr


def test_a_second_stage_bar_closes_the_first_and_late_calls_are_ignored():
    from sensorsel.cli.progress import Display

    first = Display("greedy", terminal=True)
    second = Display("certificate", after=first, terminal=True)
    with first, second:
        first(1, 4)
        drawn = first.bar
        assert drawn.pos == 1 and drawn.length == 4
        second(1, 3)  # the certificate starts: the greedy bar is completed and closed
        assert first.closed and drawn.pos == drawn.length == 4
        first(2, 4)  # a late call of a closed bar draws nothing and does not fail
        assert first.closed and drawn.pos == 4
        second(3, 3)
        assert second.bar.pos == 3
    assert second.closed
