"""Integrity on the real maps: the steps and tables of ``docs/regenerate.py`` behind
``docs/results-integrity.md`` (results under ``docs/results/integrity/``, the calibration plots under
``docs/img/integrity/``).

Steps (``python docs/regenerate.py --only integrity-kitti``, or one of them):

    integrity-03, integrity-00   the published suites of docs/results/ (the $110,000 greedy answer,
                                 the cheapest suites meeting local streets and freeway accuracy) and
                                 one sensor of each model alone, on the KITTI route with its real pole
                                 map: the map model (5 cm), the map with the lever, SLAM
    integrity-domain             the domain's published suites on the seven KITTI routes (map, lever)
    integrity-helsinki           the Helsinki sample's route r002 (OpenStreetMap, the published
                                 require answer and the single sensors)
    integrity-proof03, -proof00  whether any suite of the library can meet 10⁻⁸/h (map model), by
                                 the two monotone bounds; proof00 is slow (the whole library's floor
                                 on 00 with the lever: 13 min)
    integrity-calibration        simulate --associate on KITTI 03 against the prediction

Each suite is evaluated through the public API (:func:`sensorsel.api.suite_integrity`, the same
engine as ``sensorsel score``), its problem loaded once per step. The freeway figures reuse the
record's filter σ with the engine's own :func:`~sensorsel.information.integrity.risk.tail_risk` and
the association bound, which does not depend on the alert limits.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

#: one sensor of each model, alone (front-facing where it has a facing)
SINGLES = ("LRL-roof", "MRL-roof", "MRR-12", "LRR-12", "WSC-12", "HD2K-12", "LSC-12")
#: the lever's threshold on a measurement's bound
LEVER = 1e-3
#: the map model's map std [m] (the default of require)
MAP_SIGMA = 0.05
#: (name, map std or None for SLAM, lever threshold or None)
VARIANTS = (("map", MAP_SIGMA, None), ("map-lever", MAP_SIGMA, LEVER), ("slam", None, None))
#: Reid et al. 2019's alert limits [m, m, deg]
ALERTS = {"local-streets": (0.29, 0.29, 0.5), "freeway": (0.57, 1.40, 1.5)}
#: accuracy presets of require (95 %) [m, m, deg]
ACCURACY = {"local-streets": (0.10, 0.10, 0.17), "freeway": (0.20, 0.48, 0.51)}
Z95 = 1.959963984540054
#: the calibration runs on KITTI 03: the cheapest suite meeting freeway accuracy there
CALIBRATION_RUNS = (
    ("map", ["--map-sigma", "0.05", "--draws", "2000"]),
    ("map-is", ["--map-sigma", "0.05", "--draws", "4000", "--importance-sampling"]),
    ("slam", ["--draws", "2000"]),
)
HELSINKI_ROUTE = "r002"
#: odometry std per 1 s step (x [m], y [m], heading [rad]) of the ``map-gyro`` variant on KITTI 03: the
#: default's 0.1 m but a heading ten times better (0.001 rad, 0.06° per second: a yaw-rate gyro)
GYRO_ODOMETRY = (0.1, 0.1, 0.001)


def _suite_of(path: Path) -> list[str] | None:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    data = data.get("greedy") or data
    return list(data["suite"]) if data.get("suite") else None


def published_suites(results: Path, target: str) -> list[tuple[str, list[str]]]:
    """(label, ids) of the published answers for ``target`` ("03", "00", "domain", "helsinki")."""
    req = results / "require"
    files = {
        "03": [("greedy $110,000", results / "greedy03.json")],
        "00": [("greedy $110,000", results / "greedy00.json")],
        "domain": [("greedy $110,000", results / "domain.json")],
        "helsinki": [],
    }[target]
    name = {"helsinki": "helsinki"}.get(target, f"{target}-local-streets-a0")
    files.append(("require local-streets", req / f"require-{name}.json"))
    if target != "helsinki":
        files.append(("require freeway", req / f"require-{target}-freeway-a0.json"))
    out = []
    for label, path in files:
        suite = _suite_of(path)
        if suite is None:
            raise SystemExit(f"regenerate: integrity needs {path} (run its step first)")
        out.append((label, suite))
    return out


def summarise(rec: Any, library: Any) -> dict[str, Any]:
    """One route's integrity record, reduced to what the tables show (per hour, per sensor model)."""
    from sensorsel.information.integrity import IntegritySpec
    from sensorsel.information.integrity.risk import tail_risk

    pw = np.asarray(rec.p_wrong_association, float)
    est = np.asarray(rec.p_wrong_association_estimate, float)
    n_h = float(rec.keyframes_per_hour)
    k = len(pw)
    hours = k / n_h if n_h > 0 else 0.0
    sig = np.column_stack([rec.longitudinal_sigma_m, rec.lateral_sigma_m, np.radians(rec.heading_sigma_deg)])
    cov = np.zeros((k, 3, 3))
    for i in range(3):
        cov[:, i, i] = sig[:, i] ** 2
    per_hour, tail_h = {}, {}
    for name, (lat, lon, head) in ALERTS.items():
        spec = IntegritySpec(alert_lateral_m=lat, alert_longitudinal_m=lon, alert_heading_deg=head)
        tail = tail_risk(cov, spec)
        per_hour[name] = float(n_h * np.mean(np.minimum(1.0, tail + pw))) if k else 0.0
        tail_h[name] = float(n_h * np.mean(tail)) if k else 0.0
    worst95 = [Z95 * max(rec.lateral_sigma_m), Z95 * max(rec.longitudinal_sigma_m), Z95 * max(rec.heading_sigma_deg)]
    model_of = {s.id: s.model.code for s in library.sensors}
    sensors = []
    for x in rec.by_sensor:
        sensors.append(
            {
                "sensor": x.sensor,
                "model": model_of.get(x.sensor, x.sensor.split("-")[0]),
                "measurements": x.measurements,
                "used": x.used,
                "expected_wrong": x.expected_wrong,
                "expected_wrong_bound": x.expected_wrong_bound,
                "worst_bound": x.worst_bound,
                "wrong_per_hour_estimate": x.expected_wrong / hours if hours else 0.0,
                "wrong_per_hour_bound": x.expected_wrong_bound / hours if hours else 0.0,
            }
        )
    lat = np.asarray(rec.protection_level_lateral_m, float)
    lon = np.asarray(rec.protection_level_longitudinal_m, float)
    fin = np.isfinite(lat)
    worst = int(np.argmax(pw)) if k else -1
    return {
        "route": rec.route,
        "model": rec.model,
        "keyframes": k,
        "keyframes_per_hour": n_h,
        "hours": hours,
        "integrity_risk_per_hour": rec.integrity_risk_per_hour,
        "per_hour": per_hour,
        "tail_per_hour": tail_h,
        "association_per_hour": float(n_h * np.mean(pw)) if k else 0.0,
        "association_estimate_per_hour": float(n_h * np.mean(est)) if k else 0.0,
        "worst_keyframe": worst,
        "worst_bound": float(pw[worst]) if k else 0.0,
        "worst_estimate": float(est[worst]) if k else 0.0,
        "keyframes_bound_one": int(np.sum(pw >= 1.0)),
        "protection_level_lateral_median_m": float(np.median(lat[fin])) if fin.any() else math.inf,
        "protection_level_longitudinal_median_m": float(np.median(lon[fin])) if fin.any() else math.inf,
        "keyframes_without_protection_level": int(np.sum(~fin)),
        "n_measured": int(sum(rec.n_measured)),
        "n_used": int(sum(rec.n_used)),
        "worst_95_m_m_deg": worst95,
        "meets_accuracy": [name for name, lim in ACCURACY.items() if all(w <= b for w, b in zip(worst95, lim))],
        "by_sensor": sensors,
    }


def evaluate(
    target: Any,
    runs: list[tuple[str, list[str]]],
    *,
    singles: bool,
    variants: tuple = VARIANTS,
    keep_records: bool = False,
) -> dict[str, Any]:
    """Every suite of ``runs`` (and each of :data:`SINGLES` in the map model when ``singles``) in each
    variant: the summaries, each run's seconds, and (``keep_records``) the engine's full records."""
    from sensorsel.api import suite_integrity
    from sensorsel.information.integrity import IntegritySpec
    from sensorsel.io import results

    library = target.library
    todo = [(label, suite, v) for label, suite in runs for v in variants]
    if singles:
        todo += [(f"{s} alone", [s], v) for s in SINGLES for v in variants if v[0] != "map-lever"]
    out = []
    for label, suite, (variant, map_sigma, lever) in todo:
        singles_run = label.endswith(" alone")
        t0 = time.perf_counter()
        recs = suite_integrity(target, suite, IntegritySpec(max_association_risk=lever), map_sigma_m=map_sigma)
        dt = time.perf_counter() - t0
        cost = float(sum(library.sensors[i].cost_usd for i in library.resolve_suite(suite)))
        row: dict[str, Any] = {
            "label": label,
            "suite": suite,
            "cost_usd": cost,
            "variant": variant,
            "map_sigma_m": map_sigma,
            "max_association_risk": lever,
            "seconds": round(dt, 1),
            "routes": [summarise(r, library) for r in recs],
        }
        if keep_records and not singles_run:
            row["records"] = [json.loads(results.dumps(r)) for r in recs]
        out.append(row)
        print(f"    {label} [{variant}]: {dt:.1f} s", flush=True)
    return {"format": 1, "alerts": ALERTS, "accuracy_presets": ACCURACY, "lever": LEVER, "runs": out}


def _write(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=1, allow_nan=True) + "\n")
    tmp.replace(path)


def step_kitti(seq: str) -> Callable[[Any], None]:
    """The published suites and the single sensors on KITTI ``seq`` (real pole map)."""

    def run(c: Any) -> None:
        if c.landmarks != "real":
            return
        from sensorsel import ScenarioSpec, load_problem

        c.log.append(f"python: suite_integrity on KITTI {seq} (docs/regenerate_integrity.py)")
        spec = ScenarioSpec(seq=seq, kitti_root=c.kitti_root, landmarks="real")
        runs = published_suites(c.out, seq)
        data = evaluate(load_problem(spec), runs, singles=True, keep_records=seq == "03")
        if seq == "03":  # the same with a gyro-aided heading: what the prediction's heading costs
            from sensorsel.model.problem import GraphSettings

            gyro = load_problem(spec, settings=GraphSettings(odometry_sigmas=GYRO_ODOMETRY))
            data["runs"] += evaluate(gyro, runs, singles=True, variants=(("map-gyro", MAP_SIGMA, None),))["runs"]
            data["gyro_odometry_sigmas"] = GYRO_ODOMETRY
        _write(c.out / "integrity" / f"kitti{seq}.json", data)

    return run


def step_domain(repo: Path) -> Callable[[Any], None]:
    def run(c: Any) -> None:
        if c.landmarks != "real":
            return
        import os

        from sensorsel.model.problem import load_domain

        c.log.append("python: suite_integrity on configs/domain_kitti.yaml (docs/regenerate_integrity.py)")
        old = os.environ.get("SENSORSEL_KITTI_ROOT")
        os.environ["SENSORSEL_KITTI_ROOT"] = c.kitti_root
        try:
            d = load_domain(repo / "configs" / "domain_kitti.yaml")
        finally:
            if old is None:
                del os.environ["SENSORSEL_KITTI_ROOT"]
            else:
                os.environ["SENSORSEL_KITTI_ROOT"] = old
        data = evaluate(d, published_suites(c.out, "domain"), singles=False, variants=VARIANTS[:2])
        _write(c.out / "integrity" / "domain.json", data)

    return run


def step_helsinki(c: Any) -> None:
    """The Helsinki sample (``sensorsel osm --sample helsinki``), route r002 only (a one-route domain
    file written beside the sample's, so that only it is loaded)."""
    if c.landmarks != "real":
        return
    import yaml

    from sensorsel.model.problem import load_domain

    city = c.out / "require" / "helsinki"
    if not (city / "domain.yaml").is_file():
        c.run("osm", "--sample", "helsinki", "--output-dir", str(city))
    full = yaml.safe_load((city / "domain.yaml").read_text())
    entry = next(r for r in full["routes"] if r["name"] == HELSINKI_ROUTE)
    one = city / f"domain-{HELSINKI_ROUTE}.yaml"
    one.write_text(
        yaml.safe_dump({k: v for k, v in full.items() if k != "routes"} | {"routes": [entry]}, sort_keys=False)
    )
    c.log.append(f"python: suite_integrity on {HELSINKI_ROUTE} of the Helsinki sample (docs/regenerate_integrity.py)")
    route = load_domain(one).routes[0]
    data = evaluate(route.problem, published_suites(c.out, "helsinki"), singles=True)
    with open(city / entry["landmarks"]) as f:
        n_landmarks = sum(1 for line in f if line.strip()) - 1  # one header line
    km = float(entry["weight"]["km"])
    data |= {"route": HELSINKI_ROUTE, "landmarks": n_landmarks, "route_km": km, "landmarks_per_km": n_landmarks / km}
    _write(c.out / "integrity" / "helsinki.json", data)


def step_calibration(c: Any) -> None:
    """simulate --associate on KITTI 03 with the cheapest suite meeting freeway accuracy there."""
    if c.landmarks != "real":
        return
    suite = ",".join(published_suites(c.out, "03")[2][1])
    for name, extra in CALIBRATION_RUNS:
        d = c.out / "integrity" / f"calibration03-{name}"
        c.run(
            "simulate",
            *c.scen("03"),
            "--suite",
            suite,
            "--associate",
            "--seed",
            "0",
            *extra,
            "-q",
            "--output-dir",
            str(d),
            stdout=c.out / "integrity" / f"calibration03-{name}.txt",
        )
        png = d / "association_calibration.png"
        dst = c.img.parent / "integrity" / f"calibration03-{name}.png"
        dst.parent.mkdir(parents=True, exist_ok=True)
        png.replace(dst)


# ------------------------------------------------------------------------------------------- tables

TARGETS = (
    ("kitti03", "KITTI 03"),
    ("kitti00", "KITTI 00"),
    ("domain", "seven KITTI routes"),
    ("helsinki", f"Helsinki {HELSINKI_ROUTE} (OSM)"),
)


def _g(x: float) -> str:
    """A rate as the tables print it: two significant digits, 0 below 1e-99, inf as ∞."""
    if math.isinf(x):
        return "∞"
    if x < 1e-99:
        return "0"
    return f"{x:.2g}"


def _pl(x: float, n: int, k: int) -> str:
    return f"none ({n}/{k})" if math.isinf(x) else f"{x:.2f} ({n}/{k} none)" if n else f"{x:.2f}"


def _load(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _suite_rows(data: dict, singles: bool) -> list[str]:
    rows = []
    for run in data["runs"]:
        if run["label"].endswith(" alone") != singles:
            continue
        for r in run["routes"]:
            where = f" ({r['route']})" if len(run["routes"]) > 1 else ""
            acc = r["worst_95_m_m_deg"]
            pl = _pl(r["protection_level_lateral_median_m"], r["keyframes_without_protection_level"], r["keyframes"])
            rows.append(
                f"| {run['label']}{where} | {_short_ids(run['suite'])} | ${run['cost_usd']:,.0f} | {run['variant']} | "
                f"{_g(r['per_hour']['local-streets'])} | {_g(r['per_hour']['freeway'])} | "
                f"{_g(r['association_per_hour'])} | "
                f"{_g(r['association_estimate_per_hour'])} | {_g(r['tail_per_hour']['local-streets'])} | "
                f"{_g(r['worst_bound'])} / {_g(r['worst_estimate'])} | "
                f"{pl} | "
                f"{r['n_used']:,}/{r['n_measured']:,} | {acc[0]:.3f} / {acc[1]:.3f} / {acc[2]:.2f} | "
                f"{', '.join(r['meets_accuracy']) or 'neither'} |"
            )
    return rows


def _short_ids(ids: list[str]) -> str:
    return ", ".join(ids) if len(ids) <= 4 else ", ".join(ids[:3]) + f" +{len(ids) - 3}"


SUITE_HEADER = [
    "| suite | sensors | cost | model | risk/h local streets | risk/h freeway | association bound/h | "
    "association estimate/h | error tail/h (local) | worst keyframe P(wrong) bound / estimate | "
    "median lateral PL [m] (keyframes without) | measurements used | 95% worst lat / lon [m] / heading [deg] | "
    "meets accuracy |",
    "|---|---|---:|---|---:|---:|---:|---:|---:|---|---|---:|---|---|",
]


def _sensor_rows(data: dict) -> list[str]:
    """Per sensor model: each single sensor alone, map and SLAM (wrong associations per hour)."""
    by: dict[str, dict[str, dict]] = {}
    for run in data["runs"]:
        if not run["label"].endswith(" alone"):
            continue
        for r in run["routes"]:
            for s in r["by_sensor"]:
                by.setdefault(s["sensor"], {})[run["variant"]] = s
    rows = []
    for sensor, v in by.items():
        cells = []
        for variant in ("map", "slam", "map-gyro"):
            s = v.get(variant)
            cells += (
                [_g(s["wrong_per_hour_estimate"]), _g(s["wrong_per_hour_bound"]), _g(s["worst_bound"])]
                if s
                else ["-", "-", "-"]
            )
        m = v.get("map")
        rows.append(
            f"| {sensor} | {m['model'] if m else '?'} | {m['measurements'] if m else '-'} | " + " | ".join(cells) + " |"
        )
    return rows


SENSOR_HEADER = [
    "| sensor (alone) | model | measurements | map: wrong/h estimate | map: bound | map: worst P | "
    "SLAM: wrong/h estimate | SLAM: bound | SLAM: worst P | gyro-aided map: wrong/h estimate | bound | worst P |",
    "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
]


def _lever_rows(data: dict) -> list[str]:
    """Per sensor of each published suite: measurements left out by the lever and wrong associations
    per hour (estimate) with every measurement and with the lever."""
    runs = {(r["label"], r["variant"]): r for r in data["runs"] if not r["label"].endswith(" alone")}
    rows = []
    for (label, variant), full in runs.items():
        lever = runs.get((label, "map-lever"))
        if variant != "map" or lever is None:
            continue
        for rf, rl in zip(full["routes"], lever["routes"]):
            if len(full["routes"]) > 1:
                continue
            sl = {s["sensor"]: s for s in rl["by_sensor"]}
            for s in rf["by_sensor"]:
                t = sl[s["sensor"]]
                left = s["measurements"] - t["used"]
                rows.append(
                    f"| {label} | {s['sensor']} | {left}/{s['measurements']} "
                    f"({100 * left / max(1, s['measurements']):.0f}%) | "
                    f"{_g(s['wrong_per_hour_estimate'])} | {_g(s['wrong_per_hour_bound'])} | "
                    f"{_g(t['wrong_per_hour_estimate'])} | {_g(t['wrong_per_hour_bound'])} |"
                )
    return rows


LEVER_HEADER = [
    f"| suite | sensor | left out at {LEVER:g} | wrong/h estimate | bound | with the lever: estimate | bound |",
    "|---|---|---:|---:|---:|---:|---:|",
]


def tables(root: Path) -> str:
    """docs/results/integrity/tables.md: every integrity table on the real maps, from the files."""
    d = root / "integrity"
    out = [
        "# Integrity on the real maps (generated)",
        "",
        f"By `docs/regenerate.py --only integrity-kitti`. Map model: landmarks known to {MAP_SIGMA} m; "
        f"`map-lever`: the same with `--max-association-risk {LEVER:g}`; `slam`: the paper's SLAM graph. "
        "Risks per hour at 10⁻⁸/h (Reid et al. 2019); alert limits local streets 0.29 m / 0.29 m / 0.5°, "
        "freeway 0.57 m / 1.40 m / 1.5°. Every figure is the filter's (the car as it drives). "
        "PL: protection level at the per-keyframe allocation of local streets.",
        "",
    ]
    for name, title in TARGETS:
        data = _load(d / f"{name}.json")
        if not data:
            continue
        out += [f"## {title}: the published suites", ""]
        if "landmarks_per_km" in data:
            out += [
                f"{data['landmarks']} landmarks along its {data['route_km']:.2f} km: "
                f"{data['landmarks_per_km']:.0f} per km.",
                "",
            ]
        out += [*SUITE_HEADER, *_suite_rows(data, False), ""]
        rows = _sensor_rows(data)
        if rows:
            out += [
                f"### {title}: each sensor model alone (wrong associations per hour)",
                "",
                *SENSOR_HEADER,
                *rows,
                "",
            ]
            out += [
                f"### {title}: one sensor of each model alone, the whole line",
                "",
                *SUITE_HEADER,
                *_suite_rows(data, True),
                "",
            ]
        rows = _lever_rows(data)
        if rows:
            out += [f"### {title}: what the lever leaves out, per sensor (map model)", "", *LEVER_HEADER, *rows, ""]
        secs = sum(r["seconds"] for r in data["runs"])
        out += [f"{len(data['runs'])} evaluations, {secs:.0f} s of integrity (one process; shared 2-core machine).", ""]
    out += proof_rows(d)
    out += calibration_rows(d)
    return "\n".join(out) + "\n"


def _resolved(k: dict, importance: bool) -> bool:
    """As ``simulate --associate`` counts it (sensorsel.simulation.records): plain Monte Carlo, at least
    10 wrong draws; importance sampling, a relative standard error of at most 0.3."""
    if importance:
        return k["observed"] > 0 and k["standard_error"] <= 0.3 * k["observed"]
    return k["wrong_draws"] >= 10


def _lower99(k: dict, importance: bool) -> float:
    """The observed probability's 99 % lower limit as ``simulate --associate`` takes it: Clopper–Pearson
    on the counts (plain Monte Carlo), else the normal limit observed − 2.576 s.e."""
    if importance or k["wrong_draws"] < 0:
        return max(0.0, k["observed"] - 2.5758293035489004 * k["standard_error"])
    from scipy.stats import beta

    w, n = int(k["wrong_draws"]), int(k["draws"])
    return 0.0 if w == 0 else float(beta.ppf(0.005, w, n - w + 1))


def calibration_rows(d: Path) -> list[str]:
    """The prediction against ``simulate --associate`` on KITTI 03, one row per run, and the resolved
    keyframes where the estimate is off by more than 2x."""
    rows, off = [], []
    for name, _ in CALIBRATION_RUNS:
        data = _load(d / f"calibration03-{name}" / "simulation.json")
        if not data:
            continue
        for a in data["associations"]:
            is_ = bool(a["importance_sampling"])
            floor = 1e-6 if is_ else 1e-4  # what Monte Carlo resolves: plainly 1e-4, with importance sampling 1e-6
            scope = [k for k in a["keyframes"] if k["observed"] >= floor]
            res = [k for k in scope if _resolved(k, is_)]
            within = sum(k["observed"] / 2 <= k["predicted_estimate"] <= 2 * k["observed"] for k in res)
            below = sum(k["predicted_bound"] < _lower99(k, is_) for k in scope)
            rows.append(
                f"| {name} | {', '.join(a['suite'])} | {a['model']} | {a['draws']:,}{' (IS)' if is_ else ''} | "
                f"{len(a['keyframes'])} | {a['resolved']} | {a['within_factor_2']} | {a['bound_below_lower']} | "
                f"{floor:g} | {len(res)} | {within} | {below} | "
                f"{_g(a['predicted_per_hour'])} | {_g(a['bound_per_hour'])} | {_g(a['observed_per_hour'])} |"
            )
            for k in a["keyframes"]:
                if _resolved(k, is_) and not (k["observed"] / 2 <= k["predicted_estimate"] <= 2 * k["observed"]):
                    off.append(
                        f"| {name} | {k['keyframe']} | {k['n_measurements']} | {_g(k['predicted_estimate'])} | "
                        f"{_g(k['predicted_bound'])} | {_g(k['observed'])} ± {_g(k['standard_error'])} | "
                        f"{k['predicted_estimate'] / k['observed']:.2f} |"
                    )
    if not rows:
        return []
    out = [
        "## Calibration on KITTI 03: the prediction against `simulate --associate`",
        "",
        "Resolved: plain Monte Carlo, at least 10 wrong draws at the keyframe; importance sampling (IS), a "
        "relative standard error of at most 0.3. Per hour: wrong associations at the route's keyframe rate.",
        "",
        "The first three counts are the simulator's over all keyframes; the next over the keyframes whose "
        "observed probability is at least what Monte Carlo resolves (10⁻⁴ plainly, 10⁻⁶ with IS).",
        "",
        "| run | suite | model | draws per keyframe | keyframes | resolved | estimate within 2x | "
        "bound below the 99% lower limit | observed at least | resolved there | within 2x there | bound below there | "
        "predicted/h estimate | bound/h | observed/h |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        *rows,
        "",
    ]
    if off:
        out += [
            "Resolved keyframes where the estimate is off by more than 2x:",
            "",
            "| run | keyframe | measurements | estimate | bound | observed ± s.e. | estimate / observed |",
            "|---|---:|---:|---:|---:|---:|---:|",
            *off,
            "",
        ]
    else:
        out += ["At every resolved keyframe of these runs the estimate is within 2x of the observed.", ""]
    return out


# -------------------------------------------------------------------- can any suite meet integrity?


def no_suite_meets(problem: Any, specs: dict[str, Any], map_sigma_m: float) -> dict[str, dict[str, Any]]:
    """Whether any suite of the library can meet each of ``specs`` (name -> IntegritySpec, one risk
    per hour, gate and lever; the alert limits may differ) on the route, by the two monotone bounds of
    :class:`~sensorsel.information.integrity.IntegrityBounds` (valid in the map model):

    1. the association floor is non-decreasing and below the risk: a suite holding a sensor whose
       floor alone exceeds the requirement fails, so a suite that meets it lies within
       L = {sensors whose floor alone is within the requirement};
    2. the tail relaxation (every measurement used) is non-increasing and below the risk: every
       suite within L has at least L's tail. If L's tail exceeds the requirement, no suite of the
       library meets it (proved).

    The floor does not depend on the alert limits: it is computed once for all ``specs``.
    """
    from sensorsel.information.filtering import forward_pass
    from sensorsel.information.integrity import IntegrityBounds
    from sensorsel.information.integrity.risk import tail_risk

    first = next(iter(specs.values()))
    allowed = range(problem.n_sensors)
    b = IntegrityBounds(problem, allowed, first, map_sigma_m=map_sigma_m)
    ids = [problem.library.sensors[i].id for i in allowed]
    floors = {ids[i]: b.association_floor([i]) for i in allowed}
    low = [i for i in allowed if floors[ids[i]] <= first.integrity_risk]
    filtered = forward_pass(problem, low, map_sigma_m=map_sigma_m).filtered
    out = {}
    for name, spec in specs.items():
        tail = float(b.keyframes_per_hour * tail_risk(filtered, spec).mean())  # = b.tail_relaxation(low) at spec
        out[name] = {
            "sensors": len(ids),
            "within_floor": [ids[i] for i in low],
            "floor_min_per_hour": min(floors.values()),
            "floor_median_per_hour": float(np.median(list(floors.values()))),
            "tail_of_within_per_hour": tail,
            "proved_none_meets": bool(tail > spec.integrity_risk),
            "floors_per_hour": floors,
        }
    return out


def step_proof(seq: str) -> Callable[[Any], None]:
    """Whether any suite can meet local-streets and freeway integrity on KITTI ``seq`` (map model,
    with and without the lever; on 03 also with the gyro-aided odometry)."""

    def run(c: Any) -> None:
        if c.landmarks != "real":
            return
        from sensorsel import ScenarioSpec, load_problem
        from sensorsel.information.integrity import IntegritySpec
        from sensorsel.model.problem import GraphSettings

        c.log.append(f"python: IntegrityBounds on KITTI {seq}, the whole library (docs/regenerate_integrity.py)")
        spec = ScenarioSpec(seq=seq, kitti_root=c.kitti_root, landmarks="real")
        problems = [("default odometry", load_problem(spec))]
        if seq == "03":
            problems.append(
                ("gyro-aided odometry", load_problem(spec, settings=GraphSettings(odometry_sigmas=GYRO_ODOMETRY)))
            )
        rows = []
        for odometry, p in problems:
            for lever in (None, LEVER):
                t0 = time.perf_counter()
                specs = {
                    name: IntegritySpec(
                        alert_lateral_m=lat,
                        alert_longitudinal_m=lon,
                        alert_heading_deg=head,
                        max_association_risk=lever,
                    )
                    for name, (lat, lon, head) in ALERTS.items()
                }
                found = no_suite_meets(p, specs, MAP_SIGMA)
                dt = round(time.perf_counter() - t0, 1)
                for name, r in found.items():
                    rows.append(
                        {"route": seq, "odometry": odometry, "lever": lever, "alerts": name, "seconds": dt, **r}
                    )
                    print(
                        f"    {odometry}, lever {lever}, {name}: proved none meets {r['proved_none_meets']}", flush=True
                    )
        _write(c.out / "integrity" / f"proof{seq}.json", {"format": 1, "map_sigma_m": MAP_SIGMA, "rows": rows})

    return run


def proof_rows(d: Path) -> list[str]:
    rows = []
    for seq in ("03", "00"):
        data = _load(d / f"proof{seq}.json")
        for r in (data or {}).get("rows", ()):
            within = r["within_floor"]
            shown = ", ".join(within) if len(within) <= 6 else ", ".join(within[:5]) + f" +{len(within) - 5}"
            lever = format(r["lever"], "g") if r["lever"] else "none"
            rows.append(
                f"| {r['route']} | {r['odometry']} | {lever} | {r['alerts']} | "
                f"{len(within)}/{r['sensors']} ({shown or '-'}) | {_g(r['tail_of_within_per_hour'])} | "
                f"{'no suite meets it (proved)' if r['proved_none_meets'] else 'not excluded'} |"
            )
    if not rows:
        return []
    return [
        "## Can any suite meet 10⁻⁸/h? (map model, the whole library)",
        "",
        "A sensor whose association floor alone (its bound at the whole library's covariance, non-decreasing in "
        "the suite) exceeds 10⁻⁸/h fails in every suite; a suite that meets the requirement lies within the "
        "others, and has at least their error tail (non-increasing in the suite).",
        "",
        "| route | odometry | lever | alert limits | sensors whose floor alone is within 10⁻⁸/h | "
        "their error tail, all used [/h] | verdict |",
        "|---|---|---|---|---|---:|---|",
        *rows,
        "",
    ]
