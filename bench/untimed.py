"""What two runs' JSON results must share to be the same answer: every key but the timings.

Used by the many-core scripts (``bench/many_cores.sh``, ``bench/many_cores_require.sh``) to check
that a run on N processes gave --jobs 1's result."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def untimed(o: Any) -> Any:
    """``o`` (a loaded JSON value) without the keys that start with "seconds", at any depth."""
    if isinstance(o, dict):
        return {k: untimed(v) for k, v in o.items() if not k.startswith("seconds")}
    if isinstance(o, list):
        return [untimed(x) for x in o]
    return o


def load_untimed(path: str | Path) -> Any:
    """The JSON file at ``path``, without its timings."""
    return untimed(json.loads(Path(path).read_text()))
