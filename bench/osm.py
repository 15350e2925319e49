"""OpenStreetMap speed, one run side by side: reading + projecting the Helsinki extract (target <= 2 s)
and the whole Helsinki-centre domain's greedy at $110,000 (target <= 60 s on the 2-core machine).

    python bench/osm.py [--greedy-only | --read-only]
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from sensorsel.io.resources import sample_osm_dir


def main() -> None:
    from sensorsel.model.osm.city import build_city, write_city
    from sensorsel.model.osm.extract import DEFAULT_CLASSES, parse_roads, read_osm

    path = sample_osm_dir() / "helsinki.osm.pbf"
    t0 = time.perf_counter()
    ex = read_osm(path, roads=parse_roads(None))
    t1 = time.perf_counter()
    print(
        f"read+project  {t1 - t0:6.2f} s  ({ex.n_nodes} nodes, {len(ex.landmarks)} landmarks, {len(ex.ways)} road "
        "ways; target <= 2 s)"
    )
    if "--read-only" in sys.argv:
        return
    city = build_city(ex, DEFAULT_CLASSES)
    t2 = time.perf_counter()
    print(f"routes        {t2 - t1:6.2f} s  ({len(city.routes)} routes, {city.driven_m / 1000:.2f} km)")
    from sensorsel.api import run_greedy
    from sensorsel.model.problem import load_domain

    with tempfile.TemporaryDirectory() as tmp:
        domain = write_city(city, ex, Path(tmp) / "city", command="bench/osm.py")
        t3 = time.perf_counter()
        d = load_domain(domain)
        t4 = time.perf_counter()
        res = run_greedy(d, 110000)
        t5 = time.perf_counter()
    print(f"load domain   {t4 - t3:6.2f} s  ({len(d.routes)} routes)")
    print(f"greedy        {t5 - t4:6.2f} s")
    print(f"domain+greedy {t5 - t3:6.2f} s  (target <= 60 s); suite {', '.join(res.suite)}")


if __name__ == "__main__":
    main()
