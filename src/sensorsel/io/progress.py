"""The one progress signature of sensorsel (base layer).

Every long-running function takes ``progress: Progress | None = None`` and calls
``progress(done, total)`` after each unit of work (a pick, a run, a period, a node): ``done`` counts
the units finished so far, ``total`` is their number, or an upper bound on it when the run may stop
early (the caller shows a finished run as complete). The CLI draws it as one progress bar on stderr
(:func:`sensorsel.cli.options.progress_bar`); notebooks may pass any such callable.
"""

from __future__ import annotations

from typing import Callable

Progress = Callable[[int, int], None]
"""progress(done, total) -> None."""

__all__ = ["Progress"]
