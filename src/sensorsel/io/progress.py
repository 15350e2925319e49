"""The one progress signature of sensorsel (base layer).

Every long-running function takes ``progress: Progress | None = None`` and calls
``progress(done, total)`` after each unit of work (a pick, a run, a period, a node): ``done`` counts
the units finished so far, ``total`` is their number, or an upper bound on it when the run may stop
early (the caller shows a finished run as complete). Any such callable will do (a notebook's
``lambda done, total: ...``).

A run that can say where it stands in words (the cost interval a search has closed to, the gap of
a bound) calls :func:`report` instead: a progress that has a ``say(text)`` method is told the text
before the count; a plain callable gets the count alone. The CLI draws both on stderr
(:mod:`sensorsel.cli.progress`: a bar on a terminal, a status line every few seconds off it).
"""

from __future__ import annotations

from collections.abc import Callable

Progress = Callable[[int, int], None]
"""progress(done, total) -> None; optionally with a method ``say(text: str) -> None``."""


def report(progress: Progress | None, done: int, total: int, text: str | None = None) -> None:
    """Tell ``progress`` (if any) that ``done`` of ``total`` units are finished, and ``text`` where the
    run stands, when it has a ``say`` method (a plain callable gets the count alone)."""
    if progress is None:
        return
    if text is not None:
        say = getattr(progress, "say", None)
        if callable(say):
            say(text)
    progress(done, total)


__all__ = ["Progress", "report"]
