"""SIGTERM ends a command as Ctrl-C does: what the run learnt is written on the way out.

A batch system's time limit, ``kill PID`` or a container stopping sends SIGTERM, which by Python's
default ends the process on the spot: no ``finally``, so a ``require`` journal written every few
seconds loses what was learnt since its last write. A real ``sensorsel`` process is sent the
signal between two of the journal's timed writes (:data:`JOURNAL_EVERY_S` apart), and the journal
it leaves must hold more answers than the last timed write did.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from sensorsel.designs.requirements.design import JOURNAL_EVERY_S

REPO = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _answers(path: Path) -> int:
    return len(json.loads(path.read_text())["answers"])


def _started(out: Path, **popen: object) -> tuple[subprocess.Popen[str], Path]:
    """The README tour's ``require -o OUT`` as a real process, once its journal is first written
    (or the process has ended, or two minutes have passed), and the journal's path."""
    journal = Path(str(out) + ".checkpoint")
    proc = subprocess.Popen(
        [str(Path(sys.executable).parent / "sensorsel"), "require", "--preset", "local-streets", "-q", "-o", str(out)],
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        **popen,  # type: ignore[call-overload]
    )
    deadline = time.monotonic() + 120
    while not journal.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    return proc, journal


def test_sigterm_writes_the_journal_and_exits_143_without_a_traceback(tmp_path):
    out = tmp_path / "require.json"
    proc, journal = _started(out)
    try:
        assert journal.exists(), f"no journal before the run ended (exit {proc.poll()})"
        timed = _answers(journal)
        # half the interval: the next timed write is not due yet, the search goes on learning
        time.sleep(JOURNAL_EVERY_S / 2)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 143, err
    assert "sensorsel: terminated" in err and "Traceback" not in err
    assert _answers(journal) > timed  # written on the way out: what the run learnt after the timed write
    assert not out.exists()  # no result: the run did not end


def test_a_command_started_with_sigterm_ignored_keeps_ignoring_it(tmp_path):
    """A parent that starts sensorsel with SIGTERM ignored (as nohup ignores SIGHUP) means it: the
    command does not take the signal over, as Python leaves an ignored SIGINT alone."""
    proc, _ = _started(tmp_path / "require.json", preexec_fn=lambda: signal.signal(signal.SIGTERM, signal.SIG_IGN))
    try:
        proc.send_signal(signal.SIGTERM)
        time.sleep(1.0)
        assert proc.poll() is None  # still searching: the signal was ignored
    finally:
        proc.kill()
        proc.communicate(timeout=60)
