"""How much of a stopped `require` search a resumed run computes again: the search stopped at a time
limit (its journal kept, as `sensorsel require -o FILE --time-limit S` keeps it), then resumed from
that journal as written (the answers, the failing suites' bad keyframes and the integer programs'
solutions), from it without the programs, and from its answers alone (as journals held before the
other two were kept), side by side in one process, with the whole search beside them.

    python bench/require_resume.py [--kitti-root ../shared/kitti] [--rows tour 00]
                                   [--presets local-streets] [--stop-after 4 25]

Rows as in bench/require.py ("tour": the README's bundled route; "00": KITTI 00 with its real pole
map; "drive", "helsinki", "fixtures"); ``--stop-after`` gives each row's time limit [s], in order.
Printed per run: the status, cost, accuracy computations, integer programs (and of them those read
back), the answers read back, the wall time and the process's CPU time (less sensitive to other
work on the machine).
What to read: the resumed run's time against the whole search's less the stopped run's (what a
lossless resume would take), and the two resumed runs' computations, which do not depend on the
machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from require import _problem  # the rows of bench/require.py


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", "../shared/kitti"))
    ap.add_argument("--rows", nargs="+", default=["tour", "00"])
    ap.add_argument("--helsinki", default=None)
    ap.add_argument("--presets", nargs="+", default=["local-streets"])
    ap.add_argument("--stop-after", nargs="+", type=float, default=[4.0, 25.0])
    a = ap.parse_args()
    if len(a.stop_after) < len(a.rows):
        ap.error("--stop-after: one time limit [s] per row")

    from sensorsel.designs.requirements import preset, require
    from sensorsel.io import results

    print(
        f"{'row':8} {'preset':14} {'run':26} {'status':8} {'cost':>9} {'checks':>6} {'programs':>8} "
        f"{'read':>5} {'answers':>7} {'wall [s]':>8} {'CPU [s]':>7}"
    )
    for row, stop in zip(a.rows, a.stop_after):
        target = _problem(row, a.kitti_root, a.helsinki)
        for name in a.presets:
            spec = preset(name)

            def run(label: str, **kw: object) -> None:
                t, cpu = time.perf_counter(), time.process_time()
                r = require(target, spec, map_sigma_m=0.05, **kw)
                wall, cpu = time.perf_counter() - t, time.process_time() - cpu
                print(
                    f"{row:8} {name:14} {label:26} {r.status:8} {r.cost_usd:9,.0f} {r.n_checks:6d} "
                    f"{r.iterations + r.tie_programs:8d} {r.n_programs_resumed:5d} {r.n_resumed:7d} "
                    f"{wall:8.1f} {cpu:7.1f}",
                    flush=True,
                )

            with tempfile.TemporaryDirectory() as tmp:
                journal = Path(tmp) / "r.json.checkpoint"
                run("whole search")
                run(f"stopped at {stop:g} s", time_limit_s=stop, checkpoint=journal)
                kept = results.load(journal, "requirement-journal")
                variants = {
                    "resumed: as written": {},
                    "resumed: without programs": {"programs": ()},
                    "resumed: answers alone": {"programs": (), "bad_keyframes": ()},
                }
                for label, drop in variants.items():
                    copy = Path(tmp) / f"{len(drop)}.checkpoint"
                    results.save(dataclasses.replace(kept, **drop), copy, compact=True)
                    run(label, checkpoint=copy, resume=True)


if __name__ == "__main__":
    main()
