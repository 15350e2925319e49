#!/usr/bin/env bash
# `require --domain` past 2 cores, for a machine with many (measured on 16; docs/guide-cluster.md):
#
#   SENSORSEL_KITTI_ROOT=/path/to/kitti bench/many_cores_require.sh OUTDIR HELSINKI.yaml [KITTI.yaml]
#
# HELSINKI.yaml: the domain `sensorsel osm --sample helsinki --output-dir DIR` writes (DIR/domain.yaml);
# KITTI.yaml: a domain of KITTI routes (e.g. 03, 04, 06 and 10 of configs/domain_kitti.yaml).
# 1. `require --domain HELSINKI.yaml --preset local-streets` at --jobs 1, 2, 4, 8 and all cores;
# 2. `require --domain KITTI.yaml --preset freeway` at --jobs 1 and 4.
# Wall and CPU of each (this process and its children), and each JSON compared with --jobs 1's
# (every key but the timings). A summary on standard output and OUTDIR/require.log.
set -u
out=${1:?usage: bench/many_cores_require.sh OUTDIR HELSINKI.yaml [KITTI.yaml]}
helsinki=${2:?usage: bench/many_cores_require.sh OUTDIR HELSINKI.yaml [KITTI.yaml]}
kitti=${3:-}
mkdir -p "$out"
py=${PYTHON:-python3}
n=$(nproc)
cd "$(dirname "$0")/.."
export PYTHONPATH="$PWD/src${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
# wall time (the CPU `time` adds up is this process's alone where worker processes run the routes)
TIMEFORMAT="%R s wall, %U+%S s CPU"
run() {  # NAME DOMAIN PRESET JOBS
    echo "require --domain $2 --preset $3 --jobs $4:"
    { time $py -c 'import sys; from sensorsel.cli import main; sys.argv[0] = "sensorsel"; main()' \
        require --domain "$2" --preset "$3" --jobs "$4" -q --json >"$out/$1-jobs-$4.json" 2>"$out/$1-jobs-$4.err"; } 2>&1
}
{
    for j in 1 2 4 8 "$n"; do run helsinki "$helsinki" local-streets "$j"; done
    if [ -n "$kitti" ]; then for j in 1 4; do run kitti "$kitti" freeway "$j"; done; fi
} 2>&1 | tee "$out/require.log"
$py - "$out" <<'PY' | tee -a "$out/require.log"
import json, sys
from pathlib import Path
sys.path.insert(0, "bench")
from untimed import untimed
out = Path(sys.argv[1])
for name in ("helsinki", "kitti"):
    runs = sorted(out.glob(f"{name}-jobs-*.json"), key=lambda p: int(p.stem.rsplit("-", 1)[1]))
    if not runs:
        continue
    ref = json.loads(runs[0].read_text())
    print(f"{name}: ${ref['cost_usd']:,.0f} {ref['status']}, {ref['n_checks']} accuracy computations, {ref['iterations']} programs")
    for p in runs:
        d = json.loads(p.read_text())
        print(f"  {p.stem}: solver {d['seconds']:.1f} s (checks {d['seconds_checks']:.1f} s, programs "
              f"{d['seconds_programs']:.1f} s); the same result as --jobs 1: {untimed(d) == untimed(ref)}")
PY
