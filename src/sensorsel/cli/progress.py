"""The one progress display of the CLI: :data:`sensorsel.io.progress.Progress` drawn on stderr.

A long run calls ``progress(done, total)`` after each unit of work and may say where it stands in
words (``progress.say(text)``, through :func:`sensorsel.io.progress.report`). On a terminal that is a
bar (or, where a count says nothing of what is left, one line rewritten in place) with the text
beside it; off a terminal (a log, a pipe, CI) it is a plain status line on stderr every few seconds,
so that a log shows the run is alive and where it is::

    sensorsel: study cells: 3 of 8 (38%), 41 s, about 68 s left
    sensorsel: searching: cost in [$2,441, $2,840], 12 integer programs, 57 suites checked; 9 s

and one last line when it ends. ``--progress/--no-progress`` (or ``$SENSORSEL_PROGRESS``) forces it on
or off; ``-q`` turns it off unless ``--progress`` is given. ``$SENSORSEL_PROGRESS_EVERY`` sets the
seconds between status lines (default 5).
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Callable
from typing import Any, TextIO, TypeVar

import click

from sensorsel.errors import InputError
from sensorsel.io.progress import Progress

PROGRESS_ENV = "SENSORSEL_PROGRESS"
EVERY_ENV = "SENSORSEL_PROGRESS_EVERY"
DEFAULT_EVERY_S = 5.0
_META = "sensorsel.progress"  # where --progress/--no-progress leaves its value in the click context
F = TypeVar("F", bound=Callable[..., Any])


def progress_flag(fn: F) -> F:
    """--progress/--no-progress (default: shown unless -q), kept in the click context for :func:`progress_bar`."""

    def keep(ctx: click.Context, param: click.Parameter, value: bool | None) -> None:
        ctx.meta[_META] = value

    return click.option(
        "--progress/--no-progress",
        default=None,
        envvar=PROGRESS_ENV,
        show_envvar=True,
        expose_value=False,
        callback=keep,
        is_eager=True,
        help="Show progress on stderr (a bar on a terminal; off it, a status line every few seconds) "
        "or not. Default: shown unless -q.",
    )(fn)


def every_s() -> float:
    """Seconds between two status lines off a terminal: ``$SENSORSEL_PROGRESS_EVERY`` or 5."""
    raw = os.environ.get(EVERY_ENV, "").strip()
    if not raw:
        return DEFAULT_EVERY_S
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise InputError(f"${EVERY_ENV}={raw!r}: expected a number of seconds >= 0")
    return value


def on_terminal() -> bool:
    return sys.stderr.isatty()


def _duration(s: float) -> str:
    s = max(0.0, s)
    if s < 60:
        return f"{s:.0f} s"
    if s < 3600:
        return f"{int(s // 60)} min {int(s % 60):02d} s"
    return f"{int(s // 3600)} h {int(s % 3600 // 60):02d} min"


class Display:
    """progress(done, total) and progress.say(text) -> stderr; ``phases`` runs fill one count in turn.

    Args:
        label: what is being done ("study cells", "searching").
        phases: runs that fill the count one after another (best-of: uniform, then marginal).
        after: the display of the previous stage of the same run, completed when this one starts.
        counted: whether done/total says what is left (False: the count is only a cap, as the
            integer programs of ``require``: only the text and the time are shown).
        eta: whether the time left may be estimated from the rate so far (units of like cost).
        terminal: draw for a terminal (default: whether stderr is one).
        every: seconds between status lines off a terminal (default :func:`every_s`).
    """

    def __init__(
        self,
        label: str,
        phases: int = 1,
        after: Display | None = None,
        *,
        counted: bool = True,
        eta: bool = True,
        terminal: bool | None = None,
        every: float | None = None,
        stream: TextIO | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.label, self.phases, self.after, self.counted, self.eta = label, phases, after, counted, eta
        self.terminal = on_terminal() if terminal is None else terminal
        self.every = every_s() if every is None else every
        self.stream, self.clock = stream, clock
        self.bar: Any = None  # the click bar (terminal, counted); False once closed
        self.closed = False
        self.entered: float | None = None  # when the run began (the with block)
        self.started: float | None = None  # when this display's first count came
        self.last_line: float | None = None
        self.offset = self.last = self.last_total = 0
        self.pos, self.length = 0, 1
        self.text = ""
        self.width = 0  # of the line drawn in place (terminal, not counted)

    def __enter__(self) -> Display:
        self.entered = self.clock()
        return self

    def _out(self) -> TextIO:
        return self.stream if self.stream is not None else sys.stderr

    def say(self, text: str) -> None:
        """Where the run stands, in words (shown with the next count)."""
        self.text = text

    def __call__(self, done: int, total: int) -> None:
        if self.closed:
            return
        if self.started is None:
            if self.after is not None:
                self.after.__exit__(None, None, None)
            # a stage after another starts with its first count; the first, when the run began
            self.started = self.entered if self.entered is not None and self.after is None else self.clock()
            if self.terminal and self.counted:
                self.bar = click.progressbar(
                    length=max(1, total * self.phases),
                    label=self.label,
                    file=self._out(),
                    show_pos=True,
                    item_show_func=lambda _: self.text or None,
                )
                self.bar.__enter__()
        if done < self.last:  # the next phase (best-of: the marginal run after the uniform one)
            self.offset += self.last_total
        self.last, self.last_total = done, total
        self.length = max(1, self.offset + total, self.phases * total)
        self.pos = min(self.length, self.offset + done)
        self._draw()

    def status(self, final: bool = False) -> str:
        """The status line: label, count, share and time (elapsed, and left where honest), text."""
        elapsed = self.clock() - (self.started or self.clock())
        parts = [f"sensorsel: {self.label}:"]
        if final:
            parts.append(f"done in {_duration(elapsed)}" + (f"; {self.text}" if self.text else ""))
            return " ".join(parts)
        if self.counted:
            share = self.pos / self.length
            when = _duration(elapsed)
            if self.eta and 0 < self.pos < self.length:
                when += f", about {_duration(elapsed * (self.length - self.pos) / self.pos)} left"
            parts.append(
                f"{self.pos:,} of {self.length:,} ({share:.0%}), {when}" + (f"; {self.text}" if self.text else "")
            )
        else:
            parts.append(f"{self.text or 'working'}; {_duration(elapsed)}")
        return " ".join(parts)

    def _draw(self) -> None:
        if self.terminal and self.counted:
            self.bar.length, self.bar.pos = self.length, self.pos
            self.bar.render_progress()
        elif self.terminal:
            line = self.status().removeprefix("sensorsel: ")
            self._out().write("\r" + line.ljust(self.width))
            self._out().flush()
            self.width = len(line)
        else:
            now = self.clock()
            if now - (self.last_line if self.last_line is not None else self.started or now) >= self.every:
                self._out().write(self.status() + "\n")
                self._out().flush()
                self.last_line = now

    def __exit__(self, *exc: Any) -> None:
        """Complete and close the display (once; later calls do nothing)."""
        if self.closed:
            return
        self.closed = True
        if self.started is None:
            return
        if self.bar:
            if exc[0] is None:  # the totals are upper bounds: show the run as complete
                self.bar.pos = self.bar.length
                self.bar.render_progress()
            self.bar.__exit__(*exc)
            self.bar = False
        elif self.terminal:
            self._out().write("\n")
        elif self.last_line is not None and exc[0] is None:  # a log that said the run was alive says it ended
            self._out().write(self.status(final=True) + "\n")
            self._out().flush()


def progress_bar(
    quiet: bool, label: str, phases: int = 1, after: Display | None = None, *, counted: bool = True, eta: bool = True
) -> tuple[Display | None, Progress | None]:
    """(display, progress): the CLI's one adapter of :data:`sensorsel.io.progress.Progress`, used as
    ``with display or nullcontext():`` around the run that calls ``progress(done, total)``;
    (None, None) when progress is off (-q or --no-progress; --progress wins over -q). ``after``: the
    display of the previous stage, completed when this one starts; ``counted``, ``eta``: :class:`Display`."""
    ctx = click.get_current_context(silent=True)
    forced = ctx.meta.get(_META) if ctx is not None else None  # meta: one dict for the whole command line
    shown = (not quiet) if forced is None else forced
    if not shown:
        return None, None
    display = Display(label, phases, after, counted=counted, eta=eta)
    return display, display


__all__ = [
    "DEFAULT_EVERY_S",
    "Display",
    "EVERY_ENV",
    "PROGRESS_ENV",
    "every_s",
    "on_terminal",
    "progress_bar",
    "progress_flag",
]
