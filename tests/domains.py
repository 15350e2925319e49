"""Small domains and result comparisons shared by the tests of parallel and distributed runs."""

from __future__ import annotations

import json
from pathlib import Path

from sensorsel.io import results

DATA = Path(__file__).resolve().parents[1] / "data" / "kitti_fixtures"


def untimed(obj: object) -> object:
    """A result's JSON (a record, or its JSON text) without its timings (every ``seconds`` and
    ``seconds_*`` key)."""

    def rec(o: object) -> object:
        if isinstance(o, dict):
            return {k: rec(v) for k, v in o.items() if k != "seconds" and not k.startswith("seconds_")}
        return [rec(v) for v in o] if isinstance(o, list) else o

    return rec(json.loads(obj if isinstance(obj, str) else results.dumps(obj)))


def four_routes(folder: Path, rate_hz: float) -> Path:
    """A domain file of four routes, keyframes at ``rate_hz``: the bundled suburb and three synthetic
    maps (seeds 3, 4, 5) along the bundled tiny route (at 1 Hz 53 + 3 x 10 keyframes, at 10 Hz 521 + 3 x 91)."""
    tiny = f"route: {DATA / 'poses' / 'tiny.txt'}, format: kitti, times: {DATA / 'sequences' / 'tiny' / 'times.txt'}"
    text = [f"keyframe_rate_hz: {rate_hz}", "routes:", "  - {name: suburb, fixture: suburb}"]
    text += [f"  - {{name: tiny-{seed}, {tiny}, landmarks: {{synthetic: {{seed: {seed}}}}}}}" for seed in (3, 4, 5)]
    path = folder / f"four-{rate_hz:g}.yaml"
    path.write_text("\n".join(text) + "\n")
    return path
