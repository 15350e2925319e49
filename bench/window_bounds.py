"""The windows' floors and ceilings of `sensorsel require`, this version's against another's, on the
very calls a search makes: each row's search is run once (this version) with every call to
:class:`sensorsel.information.window_bounds.WindowBounds` recorded (the suite, the keyframes, the
window and which floors the caller wanted), then the calls are replayed in one process, in their
order, on a fresh object of this version and of the module as it was at ``--against`` (read from
git: the rest of the package is this version's), alternating over ``--repeat`` rounds.

    python bench/window_bounds.py [--kitti-root ../shared/kitti] [--rows tour tiny 00 drive]
                                  [--against REV] [--repeat 3]

Rows: "tour" the README's tour (the bundled suburb route), "tiny" the bundled tiny fixture, "00"
KITTI 00 with its real pole map, "drive" a user's own drive (KITTI 00's ground truth as a route file,
generated landmarks: a long search); local-streets, no failure, one process. Printed per row: the calls
and the keyframes asked, each version's seconds (the least over the rounds) and their ratio, and
whether every floor and ceiling the two return is the same to the bit. Timings on a shared machine
are noisy: the two columns of one run are what to compare.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from require import _problem as _rows_of_require  # the rows of bench/require.py (tour, 00, drive)

REPO = Path(__file__).resolve().parents[1]
MODULE = "src/sensorsel/information/window_bounds.py"


def _problem(row: str, kitti_root: str):
    """The row's problem: the tiny fixture here, every other row as bench/require.py builds it."""
    if row == "tiny":
        from sensorsel.model.problem import load_problem
        from sensorsel.model.scenario.loading import ScenarioSpec

        return load_problem(ScenarioSpec(fixture="tiny"))
    return _rows_of_require(row, kitti_root, None)


def _recorded(problem) -> list[tuple[int, tuple[int, ...], list[int], int | None, np.ndarray | None]]:
    """The WindowBounds calls of a require search on ``problem``: (object, suite, keyframes, window,
    the floors wanted or None)."""
    from sensorsel.designs.requirements import preset, require
    from sensorsel.information import window_bounds

    calls = []
    original = window_bounds.WindowBounds.__call__

    def call(self, suite, keyframes, window=None, floors_wanted=None):
        suite, keyframes, wanted = tuple(suite), list(keyframes), []

        def asked(ceilings):
            got = np.asarray(floors_wanted(ceilings), bool)
            wanted.append(got.copy())
            return got

        out = original(self, suite, keyframes, window, None if floors_wanted is None else asked)
        calls.append((id(self), suite, keyframes, window, wanted[0] if wanted else None))
        return out

    window_bounds.WindowBounds.__call__ = call
    try:
        require(problem, preset("local-streets"), map_sigma_m=0.05, jobs=1)
    finally:
        window_bounds.WindowBounds.__call__ = original
    return calls


def _module_at(rev: str):
    """window_bounds.py as it was at ``rev``, imported as a module of its own."""
    source = subprocess.run(["git", "show", f"{rev}:{MODULE}"], cwd=REPO, capture_output=True, text=True, check=True)
    with tempfile.TemporaryDirectory() as folder:  # the file only while it is read
        path = Path(folder) / "window_bounds_before.py"
        path.write_text(source.stdout)
        spec = importlib.util.spec_from_file_location("window_bounds_before", path)
        module = importlib.util.module_from_spec(spec)
        assert spec.loader is not None
        spec.loader.exec_module(module)
    return module


def _replay(module, problem, calls) -> tuple[float, list[tuple[np.ndarray, np.ndarray]]]:
    objects: dict[int, object] = {}
    out = []
    t = time.perf_counter()
    for key, suite, keyframes, window, wanted in calls:
        bounds = objects.get(key)
        if bounds is None:
            bounds = objects[key] = module.WindowBounds(problem, 0.05)
        out.append(bounds(suite, keyframes, window, None if wanted is None else (lambda c, w=wanted: w)))
    return time.perf_counter() - t, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", nargs="+", default=["tour", "tiny", "00"])
    ap.add_argument(
        "--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti"))
    )
    ap.add_argument("--against", default="HEAD~1", help="the git revision whose window_bounds.py to compare")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    sys.path.insert(0, str(REPO / "src"))
    from sensorsel.information import window_bounds

    before = _module_at(args.against)
    print(f"this version against {args.against}; load average {os.getloadavg()[0]:.2f}")
    print(f"{'row':6s} {'calls':>6s} {'keyframes':>9s} {'this [s]':>9s} {'before [s]':>10s} {'ratio':>6s}  same bytes")
    for row in args.rows:
        problem = _problem(row, args.kitti_root)
        calls = _recorded(problem)
        best = {"this": float("inf"), "before": float("inf")}
        answers = {}
        for _ in range(args.repeat):
            for name, module in (("this", window_bounds), ("before", before)):
                seconds, answers[name] = _replay(module, problem, calls)
                best[name] = min(best[name], seconds)
        same = all(np.array_equal(a, b) for x, y in zip(answers["this"], answers["before"]) for a, b in zip(x, y))
        n_keyframes = sum(len(c[2]) for c in calls)
        print(
            f"{row:6s} {len(calls):6d} {n_keyframes:9d} {best['this']:9.2f} {best['before']:10.2f} "
            f"{best['before'] / best['this']:6.2f}  {same}"
        )
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
