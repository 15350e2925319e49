"""How long `sensorsel require` takes to prove its answer (issue 24: KITTI 00 with the local-streets
preset <= 60 s, the seven-route domain <= 3 minutes, on a 2-core machine).

    python bench/require.py [--kitti-root ../shared/kitti] [--targets 03 00 domain] [--presets local-streets]
                            [--failures 0]

Each run is the whole command in a fresh process (imports, loading, the search); printed: the
target, preset, failures, the answer, its cost and lower bound, the integer programs, the accuracy
computations and the suites refuted by the cheap floor, and the wall time.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kitti-root", default=os.environ.get("SENSORSEL_KITTI_ROOT", str(REPO.parent / "shared" / "kitti")))
    ap.add_argument("--targets", nargs="+", default=["03", "00", "domain"])
    ap.add_argument("--presets", nargs="+", default=["local-streets"])
    ap.add_argument("--failures", nargs="+", type=int, default=[0])
    a = ap.parse_args()
    exe = [str(Path(sys.executable).with_name("sensorsel"))]
    env = dict(os.environ, SENSORSEL_KITTI_ROOT=a.kitti_root)
    for target in a.targets:
        where = ["--domain", str(REPO / "configs" / "domain_kitti.yaml")] if target == "domain" else ["--seq", target]
        for preset in a.presets:
            for alpha in a.failures:
                with tempfile.TemporaryDirectory() as tmp:
                    out = Path(tmp) / "r.json"
                    t0 = time.perf_counter()
                    p = subprocess.run([*exe, "require", *where, "--preset", preset, "--failures", str(alpha), "-q", "-o", str(out)],
                                       capture_output=True, text=True, env=env)
                    dt = time.perf_counter() - t0
                    if p.returncode not in (0, 2):
                        sys.exit(p.stderr)
                    r = json.loads(out.read_text())
                print(f"{target:>6} {preset:>13} a={alpha}: {r['status']:>10} {','.join(r['suite']) or '-':<40} "
                      f"${r['cost_usd']:>9,.0f} (lower bound ${float(r['lower_bound_usd']):>9,.0f}), {r['iterations']:3d} programs, "
                      f"{r['n_checks']:5d} accuracies, {r.get('n_refuted', 0):5d} refuted; {dt:6.1f} s", flush=True)


if __name__ == "__main__":
    main()
