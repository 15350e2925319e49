#!/usr/bin/env bash
# Speed-ups past 2 cores, for a machine with many (measured once on 16; docs/guide-cluster.md):
#
#   SENSORSEL_KITTI_ROOT=/path/to/kitti bench/many_cores.sh OUTDIR
#
# 1. the seven KITTI routes' lazy greedy ($110,000): 1, 2 and all threads in-process, 1, 2, 4 and 7
#    worker processes (the routes owned by processes: what --jobs N runs on a domain), LocalClusters of
#    2 and 8 Dask workers (bench/parallel.py, every run's result compared with the 1-thread one);
# 2. the same on 100 generated routes ($12,000);
# 3. the whole command a user runs, `greedy --domain configs/domain_kitti.yaml --budget 110000`,
#    at --jobs 1, 2, 4, 8 and all cores: wall and CPU, and its JSON compared with --jobs 1's.
# Five files in OUTDIR; a summary on standard output.
set -u
out=${1:?usage: bench/many_cores.sh OUTDIR}
mkdir -p "$out"
py=${PYTHON:-python3}
n=$(nproc)
cd "$(dirname "$0")/.."
export PYTHONPATH="$PWD/src${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
$py bench/parallel.py --jobs "1,2,$n" --processes 1,2,4,7 --workers 2,8 --model-at 1 \
    >"$out/kitti-greedy.json" 2>"$out/kitti-greedy.err"
tail -n 12 "$out/kitti-greedy.err"
$py bench/parallel.py --generated 100 --budget 12000 --jobs "1,$n" --processes "1,2,4,8,$n" --workers 8 \
    --model-at 1 >"$out/generated-100.json" 2>"$out/generated-100.err"
tail -n 12 "$out/generated-100.err"
TIMEFORMAT="%R s wall, %U+%S s CPU (this process and its children)"
for j in 1 2 4 8 "$n"; do
    echo "greedy --domain configs/domain_kitti.yaml --budget 110000 --jobs $j:"
    { time $py -c 'import sys; from sensorsel.cli import main; sys.argv[0] = "sensorsel"; main()' \
        greedy --domain configs/domain_kitti.yaml --budget 110000 --jobs "$j" -q --json \
        >"$out/command-jobs-$j.json" 2>/dev/null; } 2>&1
done 2>&1 | tee "$out/commands.log"
$py - "$out" "$n" <<'PY' | tee -a "$out/commands.log"
import sys
sys.path.insert(0, "bench")
from untimed import load_untimed
out, n = sys.argv[1], sys.argv[2]
ref = load_untimed(f"{out}/command-jobs-1.json")
for j in ["2", "4", "8", n]:
    same = load_untimed(f"{out}/command-jobs-{j}.json") == ref
    print(f"--jobs {j}: the same result as --jobs 1: {same}")
PY
rm -f "$out"/command-jobs-*.json
