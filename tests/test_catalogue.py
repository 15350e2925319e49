"""A catalogue of bad or odd inputs across every command.

Each case runs the command in-process (click's CliRunner) on the tiny fixture and asserts the exit
status (2 = bad input; 0 = a legitimate warning case), that no traceback is printed, and that the
message names the culprit (the file, key or option). The "silent answers" of the issue each have a
case that fails on the old behaviour: a result made with a library whose one price differs, a result
on another landmark map or another scenario, an empty --suite, and optimal / resilient with a budget
that buys nothing or more failures than the suite holds.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from sensorsel.cli import cli

REPO = Path(__file__).resolve().parents[1]
T = ["--fixture", "tiny"]
E = ["--engine", "fast", "--jobs", "1"]
Q = ["-q"]


def _invoke(args: list[str]):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    """Bad files and result files of this problem and of other problems, made once."""
    d = tmp_path_factory.mktemp("catalogue")
    (d / "empty.yaml").write_text("")
    (d / "empty.csv").write_text("")
    (d / "empty.txt").write_text("")
    (d / "empty.json").write_text("")
    for name in ("binary.yaml", "binary.csv", "binary.txt", "binary.json"):
        (d / name).write_bytes(bytes(range(256)) * 4)
    (d / "text.json").write_text("this is not json\n")
    (d / "list.json").write_text("[1, 2, 3]\n")
    (d / "nan.csv").write_text("x,y\n10,5\nnan,3\n")
    (d / "wrongcols.csv").write_text("a,b\n1,2\n")
    (d / "afile").write_text("a file, not a folder\n")
    lib = (REPO / "configs" / "sensor_library.yaml").read_text()
    first_cost = lib.index("cost_usd:")
    line_end = lib.index("\n", first_cost)
    (d / "price.yaml").write_text(lib[:first_cost] + "cost_usd: 99999" + lib[line_end:])  # one price changed, same ids
    (d / "negcost.yaml").write_text(lib[:first_cost] + "cost_usd: -5" + lib[line_end:])
    (d / "nancost.yaml").write_text(lib[:first_cost] + "cost_usd: .nan" + lib[line_end:])
    (d / "lm2.csv").write_text((REPO / "data" / "kitti_fixtures" / "landmarks" / "tiny.csv").read_text())
    (d / "study_key.yaml").write_text("target:\n  fixture: tiny\ngrid:\n  budgets: [5000]\n  colours: [red]\n")
    (d / "study_budget.yaml").write_text("target:\n  fixture: tiny\ngrid:\n  budgets: [5000, lots]\n")

    def greedy(out: str, *extra: str) -> None:
        r = _invoke(["greedy", *T, *E, *Q, "--budget", "110000", "--no-certificate", "-o", d / out, *extra])
        assert r.exit_code == 0, r.output

    greedy("g.json")
    greedy("g_price.json", "--library", d / "price.yaml")
    greedy("g_lm.json", "--landmarks", "synthetic")
    greedy("g_rate.json", "--rate", "2")
    r = _invoke(
        ["greedy", "--fixture", "suburb", *E, *Q, "--budget", "3000", "--no-certificate", "-o", d / "g_suburb.json"]
    )
    assert r.exit_code == 0, r.output
    # the same map under another path: content-based, so the same problem
    greedy("g_samemap.json", "--landmarks", d / "lm2.csv")
    data = json.loads((d / "g.json").read_text())
    old = json.loads(json.dumps(data))
    old["problem"].pop("fingerprint")  # a file written before fingerprints
    (d / "g_old.json").write_text(json.dumps(old))
    unknown = json.loads(json.dumps(data))
    unknown["suite"] = ["XYZ-1", *unknown["suite"][1:]]
    (d / "g_unknown.json").write_text(json.dumps(unknown))
    r = _invoke(["score", *T, *E, "--suite", "LRL-roof", "--json"])
    assert r.exit_code == 0, r.output
    (d / "score.json").write_text(r.stdout)
    r = _invoke(["certify", *T, *E, *Q, "--budget", "5000", "-o", d / "cert.json"])
    assert r.exit_code == 0, r.output
    return d


# (id, args with {d} for the files folder, exit status, fragments the output must hold)
CASES: list[tuple[str, list[str], int, list[str]]] = [
    # ---- library
    ("library-missing", ["library", "--library", "{d}/missing.yaml"], 2, ["missing.yaml"]),
    ("library-empty", ["library", "--library", "{d}/empty.yaml"], 2, ["empty.yaml"]),
    ("library-binary", ["library", "--library", "{d}/binary.yaml"], 2, ["binary.yaml"]),
    ("library-negative-cost", ["library", "--library", "{d}/negcost.yaml"], 2, ["negcost.yaml", "cost_usd"]),
    ("library-nan-cost", ["library", "--library", "{d}/nancost.yaml"], 2, ["nancost.yaml", "cost_usd"]),
    ("library-folder", ["library", "--library", "{d}"], 2, ["--library"]),
    # ---- score
    ("score-empty-suite", ["score", *T, "--suite", ""], 2, ["--suite"]),
    ("score-comma-suite", ["score", *T, "--suite", " , "], 2, ["--suite"]),
    ("score-unknown-id", ["score", *T, "--suite", "NOPE-1"], 2, ["NOPE-1"]),
    ("score-duplicate-id", ["score", *T, "--suite", "LRL-roof,LRL-roof"], 2, ["LRL-roof", "twice"]),
    ("score-position-out-of-range", ["score", *T, "--suite", "999"], 2, ["999"]),
    ("score-rate-zero", ["score", *T, "--rate", "0", "--suite", "LRL-roof"], 2, ["--rate"]),
    ("score-rate-nan", ["score", *T, "--rate", "nan", "--suite", "LRL-roof"], 2, ["--rate"]),
    ("score-rate-negative", ["score", *T, "--rate", "-1", "--suite", "LRL-roof"], 2, ["--rate"]),
    ("score-rate-inf", ["score", *T, "--rate", "inf", "--suite", "LRL-roof"], 2, ["--rate"]),
    (
        "score-landmarks-missing",
        ["score", *T, "--landmarks", "{d}/missing.csv", "--suite", "LRL-roof"],
        2,
        ["missing.csv"],
    ),
    ("score-landmarks-empty", ["score", *T, "--landmarks", "{d}/empty.csv", "--suite", "LRL-roof"], 2, ["empty.csv"]),
    ("score-landmarks-nan", ["score", *T, "--landmarks", "{d}/nan.csv", "--suite", "LRL-roof"], 2, ["nan.csv"]),
    (
        "score-landmarks-wrong-columns",
        ["score", *T, "--landmarks", "{d}/wrongcols.csv", "--suite", "LRL-roof"],
        2,
        ["wrongcols.csv"],
    ),
    (
        "score-landmarks-binary",
        ["score", *T, "--landmarks", "{d}/binary.csv", "--suite", "LRL-roof"],
        2,
        ["binary.csv"],
    ),
    ("score-route-missing", ["score", "--route", "{d}/missing.txt", "--suite", "LRL-roof"], 2, ["missing.txt"]),
    ("score-route-empty", ["score", "--route", "{d}/empty.txt", "--suite", "LRL-roof"], 2, ["empty.txt"]),
    ("score-poses-binary", ["score", "--route", "{d}/binary.txt", "--suite", "LRL-roof"], 2, ["binary.txt"]),
    ("score-unknown-engine", ["score", *T, "--engine", "warp", "--suite", "LRL-roof"], 2, ["--engine"]),
    (
        "score-bad-landmark-seed",
        ["score", *T, "--landmarks", "synthetic", "--landmark-seed", "-1", "--suite", "LRL-roof"],
        2,
        ["--landmark-seed"],
    ),
    ("score-unknown-fixture", ["score", "--fixture", "atlantis", "--suite", "LRL-roof"], 2, ["atlantis"]),
    (
        "score-library-missing",
        ["score", *T, "--library", "{d}/missing.yaml", "--suite", "LRL-roof"],
        2,
        ["missing.yaml"],
    ),
    ("score-jobs-zero", ["score", *T, "--jobs", "0", "--suite", "LRL-roof"], 2, ["--jobs"]),
    ("score-two-routes", ["score", "--seq", "03", "--route", "{d}/empty.txt", "--suite", "LRL-roof"], 2, ["--route"]),
    # ---- scene
    ("scene-empty-suite", ["scene", *T, "--suite", "", "-o", "{d}/s.png"], 2, ["--suite"]),
    ("scene-empty-output", ["scene", *T, "-o", ""], 2, ["--output"]),
    ("scene-bad-extension", ["scene", *T, "-o", "{d}/s.txt"], 2, ["s.txt"]),
    ("scene-format-disagrees", ["scene", *T, "-o", "{d}/s.png", "--plot-format", "svg"], 2, ["s.png", "--plot-format"]),
    ("scene-missing-folder-is-made", ["scene", *T, "-o", "{d}/nofolder/s.png"], 0, ["nofolder/s.png"]),
    ("scene-under-a-file", ["scene", *T, "-o", "{d}/afile/s.png"], 2, ["afile"]),
    ("scene-unknown-id", ["scene", *T, "--suite", "NOPE-1", "-o", "{d}/s.png"], 2, ["NOPE-1"]),
    ("scene-pose-out-of-range", ["scene", *T, "--pose", "999", "-o", "{d}/s.png"], 2, ["--pose"]),
    ("scene-pose-negative", ["scene", *T, "--pose", "-1", "-o", "{d}/s.png"], 2, ["--pose"]),
    # ---- landmarks
    ("landmarks-empty-output", ["landmarks", *T, "-o", ""], 2, ["--output"]),
    ("landmarks-bad-offset", ["landmarks", *T, "--near-offset", "abc", "-o", "{d}/lm.csv"], 2, ["--near-offset"]),
    ("landmarks-one-offset", ["landmarks", *T, "--far-offset", "5", "-o", "{d}/lm.csv"], 2, ["--far-offset"]),
    ("landmarks-tiny-spacing", ["landmarks", *T, "--near-spacing", "1e-9", "-o", "{d}/lm.csv"], 2, ["--near-spacing"]),
    (
        "landmarks-reads-landmarks",
        ["landmarks", *T, "--landmarks", "{d}/nan.csv", "-o", "{d}/lm.csv"],
        2,
        ["--landmarks"],
    ),
    ("landmarks-missing-folder-is-made", ["landmarks", *T, "-o", "{d}/nofolder/lm.csv"], 0, ["nofolder/lm.csv"]),
    ("landmarks-bad-seed", ["landmarks", *T, "--landmark-seed", "-2", "-o", "{d}/lm.csv"], 2, ["--landmark-seed"]),
    # ---- greedy
    ("greedy-negative-budget", ["greedy", *T, *E, "--budget", "-5"], 2, ["--budget"]),
    ("greedy-nan-budget", ["greedy", *T, *E, "--budget", "nan"], 2, ["--budget"]),
    ("greedy-inf-budget", ["greedy", *T, *E, "--budget", "inf"], 2, ["--budget"]),
    ("greedy-text-budget", ["greedy", *T, *E, "--budget", "lots"], 2, ["--budget", "lots"]),
    (
        "greedy-budget-buys-nothing",
        ["greedy", *T, *E, "--budget", "100"],
        2,
        ["--budget $100", "cheapest sensor", "$449"],
    ),
    ("greedy-unknown-rule", ["greedy", *T, *E, "--budget", "5000", "--rule", "cheapest"], 2, ["--rule", "cheapest"]),
    ("greedy-empty-output", ["greedy", *T, *E, "--budget", "5000", "-o", ""], 2, ["--output"]),
    (
        "greedy-missing-folder-is-made",
        ["greedy", *T, *E, *Q, "--budget", "5000", "-o", "{d}/nofolder/g.json"],
        0,
        ["nofolder/g.json"],
    ),
    ("greedy-under-a-file", ["greedy", *T, *E, "--budget", "5000", "-o", "{d}/afile/g.json"], 2, ["afile"]),
    ("greedy-no-budget", ["greedy", *T, *E], 2, ["--budget"]),
    # ---- pareto
    (
        "pareto-budgets-buy-nothing",
        ["pareto", *T, *E, *Q, "--budgets", "10,20", "--output-dir", "{d}/p"],
        2,
        ["--budgets $20", "cheapest sensor"],
    ),
    (
        "pareto-budget-buys-nothing",
        ["pareto", *T, *E, *Q, "--budget", "100", "--output-dir", "{d}/p"],
        2,
        ["--budget $100", "cheapest sensor"],
    ),
    ("pareto-text-budgets", ["pareto", *T, *E, *Q, "--budgets", "abc", "--output-dir", "{d}/p"], 2, ["abc"]),
    ("pareto-negative-budgets", ["pareto", *T, *E, *Q, "--budgets", "5000,-5", "--output-dir", "{d}/p"], 2, ["-5"]),
    ("pareto-unknown-rule", ["pareto", *T, *E, *Q, "--rules", "uniform,nope", "--output-dir", "{d}/p"], 2, ["nope"]),
    ("pareto-empty-output", ["pareto", *T, *E, *Q, "--output-dir", ""], 2, ["--output"]),
    ("pareto-output-is-a-file", ["pareto", *T, *E, *Q, "--budgets", "5000", "--output-dir", "{d}/afile"], 2, ["afile"]),
    # ---- resilient
    (
        "resilient-negative-failures",
        ["resilient", *T, *E, *Q, "--failures", "-1", "--output-dir", "{d}/r"],
        2,
        ["failures"],
    ),
    (
        "resilient-failures-beyond-library",
        ["resilient", *T, *E, *Q, "--failures", "70", "--output-dir", "{d}/r"],
        2,
        ["--failures 70"],
    ),
    (
        "resilient-budget-buys-only-the-failures",
        ["resilient", *T, *E, *Q, "--budget", "500", "--failures", "1", "--output-dir", "{d}/r"],
        2,
        ["--failures 1", "--budget"],
    ),
    (
        "resilient-budget-buys-nothing",
        ["resilient", *T, *E, *Q, "--budget", "100", "--failures", "0", "--output-dir", "{d}/r"],
        2,
        ["--budget $100", "cheapest sensor"],
    ),
    (
        "resilient-failing-set-takes-the-budget",
        ["resilient", *T, *E, *Q, "--budget", "110000", "--failures", "40", "--output-dir", "{d}/r"],
        2,
        ["--failures 40", "holds only 4"],
    ),
    ("resilient-zero-period", ["resilient", *T, *E, *Q, "--period", "0", "--output-dir", "{d}/r"], 2, ["period"]),
    ("resilient-nan-period", ["resilient", *T, *E, *Q, "--period", "nan", "--output-dir", "{d}/r"], 2, ["period"]),
    (
        "resilient-unknown-rule",
        ["resilient", *T, *E, *Q, "--rule", "nope", "--output-dir", "{d}/r"],
        2,
        ["--rule", "nope"],
    ),
    ("resilient-empty-output", ["resilient", *T, *E, *Q, "--output-dir", ""], 2, ["--output"]),
    ("resilient-output-is-a-file", ["resilient", *T, *E, *Q, "--output-dir", "{d}/afile"], 2, ["afile"]),
    # ---- certify
    ("certify-nothing-to-certify", ["certify", *T, *E, *Q], 2, ["--suite", "--budget"]),
    (
        "certify-result-and-budget",
        ["certify", *T, *E, *Q, "--suite", "{d}/g.json", "--budget", "5000"],
        2,
        ["not both"],
    ),
    ("certify-empty-result-name", ["certify", *T, *E, *Q, "--suite", ""], 2, ["--suite"]),
    ("certify-result-missing", ["certify", *T, *E, *Q, "--suite", "{d}/missing.json"], 2, ["missing.json"]),
    ("certify-result-empty", ["certify", *T, *E, *Q, "--suite", "{d}/empty.json"], 2, ["empty.json"]),
    ("certify-result-binary", ["certify", *T, *E, *Q, "--suite", "{d}/binary.json"], 2, ["binary.json"]),
    ("certify-result-not-json", ["certify", *T, *E, *Q, "--suite", "{d}/text.json"], 2, ["text.json"]),
    ("certify-result-a-list", ["certify", *T, *E, *Q, "--suite", "{d}/list.json"], 2, ["list.json", "list"]),
    (
        "certify-result-of-another-kind",
        ["certify", *T, *E, *Q, "--suite", "{d}/score.json"],
        2,
        ["score.json", "'score'", "'greedy'"],
    ),
    # inputs that could otherwise give a silently wrong answer
    (
        "certify-result-of-another-price",
        ["certify", *T, *E, *Q, "--suite", "{d}/g_price.json"],
        2,
        ["g_price.json", "another library: sensor costs or models differ", "--force"],
    ),
    (
        "certify-result-of-another-map",
        ["certify", *T, *E, *Q, "--suite", "{d}/g_lm.json"],
        2,
        ["g_lm.json", "another landmark map"],
    ),
    (
        "certify-result-of-another-rate",
        ["certify", *T, *E, *Q, "--suite", "{d}/g_rate.json"],
        2,
        ["g_rate.json", "another route or keyframe rate"],
    ),
    (
        "certify-result-of-another-scenario",
        ["certify", *T, *E, *Q, "--suite", "{d}/g_suburb.json"],
        2,
        ["g_suburb.json", "another route", "another landmark map"],
    ),
    (
        "certify-result-without-fingerprint",
        ["certify", *T, *E, *Q, "--suite", "{d}/g_old.json"],
        2,
        ["g_old.json", "no fingerprint", "--force"],
    ),
    (
        "certify-result-with-unknown-ids",
        ["certify", *T, *E, *Q, "--suite", "{d}/g_unknown.json"],
        2,
        ["g_unknown.json", "XYZ-1"],
    ),
    ("certify-budget-buys-nothing", ["certify", *T, *E, *Q, "--budget", "3"], 2, ["--budget $3", "cheapest sensor"]),
    # legitimate: forced (a warning), or the same map under another path (content-based)
    (
        "certify-forced-without-fingerprint",
        ["certify", *T, *E, *Q, "--suite", "{d}/g_old.json", "--force"],
        0,
        ["sensorsel: warning:", "g_old.json", "--force"],
    ),
    (
        "certify-forced-another-price",
        ["certify", *T, *E, *Q, "--suite", "{d}/g_price.json", "--force"],
        0,
        ["sensorsel: warning:", "g_price.json", "another library"],
    ),
    ("certify-same-map-other-path", ["certify", *T, *E, *Q, "--suite", "{d}/g_samemap.json"], 0, ["certificate"]),
    # ---- optimal
    (
        "optimal-budget-buys-nothing",
        ["optimal", *T, *E, *Q, "--budget", "100"],
        2,
        ["--budget $100", "cheapest sensor", "$449"],
    ),
    ("optimal-zero-budget", ["optimal", *T, *E, *Q, "--budget", "0"], 2, ["--budget $0", "cheapest sensor"]),
    ("optimal-negative-budget", ["optimal", *T, *E, *Q, "--budget", "-1"], 2, ["--budget"]),
    ("optimal-no-budget", ["optimal", *T, *E, *Q], 2, ["--budget"]),
    ("optimal-zero-nodes", ["optimal", *T, *E, *Q, "--budget", "5000", "--max-nodes", "0"], 2, ["--max-nodes"]),
    ("optimal-zero-seconds", ["optimal", *T, *E, *Q, "--budget", "5000", "--time-limit", "0"], 2, ["--time-limit"]),
    ("optimal-empty-output", ["optimal", *T, *E, *Q, "--budget", "5000", "-o", ""], 2, ["--output"]),
    # ---- simulate
    ("simulate-empty-suite", ["simulate", *T, *Q, "--suite", "", "--output-dir", "{d}/s"], 2, ["--suite"]),
    (
        "simulate-empty-compare",
        ["simulate", *T, *Q, "--suite", "LRL-roof", "--compare", ",", "--output-dir", "{d}/s"],
        2,
        ["--compare"],
    ),
    (
        "simulate-unknown-id",
        ["simulate", *T, *Q, "--suite", "NOPE-1", "--output-dir", "{d}/s"],
        2,
        ["--suite", "NOPE-1"],
    ),
    # a list of ids longer than a file name may be (it was tried as a path: ENAMETOOLONG, a traceback)
    (
        "simulate-long-id-list",
        [
            "simulate",
            *T,
            *Q,
            "--suite",
            ",".join(["HD2K-4"] * 2 + [f"NOPE-{k}" for k in range(60)]),
            "--output-dir",
            "{d}/s",
        ],
        2,
        ["--suite"],
    ),
    (
        "simulate-result-missing",
        ["simulate", *T, *Q, "--suite", "{d}/missing.json", "--output-dir", "{d}/s"],
        2,
        ["missing.json"],
    ),
    (
        "simulate-result-of-another-kind",
        ["simulate", *T, *Q, "--suite", "{d}/cert.json", "--output-dir", "{d}/s"],
        2,
        ["cert.json", "'certificate'"],
    ),
    (
        "simulate-result-of-another-scenario",
        ["simulate", *T, *Q, "--suite", "{d}/g_suburb.json", "--output-dir", "{d}/s"],
        2,
        ["g_suburb.json", "--suite", "another route"],
    ),
    (
        "simulate-compare-of-another-price",
        ["simulate", *T, *Q, "--suite", "LRL-roof", "--compare", "{d}/g_price.json", "--output-dir", "{d}/s"],
        2,
        ["g_price.json", "--compare", "another library"],
    ),
    (
        "simulate-result-without-fingerprint",
        ["simulate", *T, *Q, "--suite", "{d}/g_old.json", "--output-dir", "{d}/s"],
        2,
        ["g_old.json", "no fingerprint"],
    ),
    (
        "simulate-result-with-unknown-ids",
        ["simulate", *T, *Q, "--suite", "{d}/g_unknown.json", "--output-dir", "{d}/s"],
        2,
        ["g_unknown.json", "XYZ-1"],
    ),
    (
        "simulate-zero-runs",
        ["simulate", *T, *Q, "--suite", "LRL-roof", "--runs", "0", "--output-dir", "{d}/s"],
        2,
        ["--runs"],
    ),
    (
        "simulate-negative-seed",
        ["simulate", *T, *Q, "--suite", "LRL-roof", "--seed", "-1", "--output-dir", "{d}/s"],
        2,
        ["--seed"],
    ),
    (
        "simulate-nan-noise",
        ["simulate", *T, *Q, "--suite", "LRL-roof", "--noise-scale", "nan", "--output-dir", "{d}/s"],
        2,
        ["--noise-scale"],
    ),
    (
        "simulate-unknown-failure",
        ["simulate", *T, *Q, "--suite", "LRL-roof", "--fail", "NOPE-1", "--output-dir", "{d}/s"],
        2,
        ["NOPE-1"],
    ),
    (
        "simulate-two-sigmas",
        ["simulate", *T, *Q, "--suite", "LRL-roof", "--start-sigmas", "1,2", "--output-dir", "{d}/s"],
        2,
        ["--start-sigmas"],
    ),
    (
        "simulate-unknown-solver",
        ["simulate", *T, *Q, "--suite", "LRL-roof", "--solver", "magic", "--output-dir", "{d}/s"],
        2,
        ["--solver"],
    ),
    ("simulate-empty-output", ["simulate", *T, *Q, "--suite", "LRL-roof", "--output-dir", ""], 2, ["--output"]),
    (
        "simulate-output-is-a-file",
        ["simulate", *T, *Q, "--suite", "LRL-roof", "--output-dir", "{d}/afile"],
        2,
        ["afile"],
    ),
    # ---- limits besides money
    (
        "greedy-limit-unknown-resource",
        ["greedy", *T, *E, *Q, "--budget", "5000", "--limit", "heat_w=5"],
        2,
        ["--limit heat_w=5", "power_w"],
    ),
    (
        "greedy-limit-text",
        ["greedy", *T, *E, *Q, "--budget", "5000", "--limit", "power_w=lots"],
        2,
        ["--limit", "'lots'"],
    ),
    ("greedy-limit-no-value", ["greedy", *T, *E, *Q, "--budget", "5000", "--limit", "power_w"], 2, ["RESOURCE=VALUE"]),
    (
        "greedy-limit-negative",
        ["greedy", *T, *E, *Q, "--budget", "5000", "--limit", "power_w=-1"],
        2,
        ["--limit", ">= 0"],
    ),
    (
        "greedy-limit-twice",
        ["greedy", *T, *E, *Q, "--budget", "5000", "--limit", "power_w=5", "--limit", "power_w=6"],
        2,
        ["power_w", "twice"],
    ),
    (
        "greedy-require-unknown",
        ["greedy", *T, *E, *Q, "--budget", "5000", "--include", "NOPE-1"],
        2,
        ["--include", "NOPE-1"],
    ),
    (
        "greedy-require-over-limit",
        ["greedy", *T, *E, *Q, "--budget", "110000", "--include", "LRL-roof", "--limit", "power_w=10"],
        2,
        ["--include LRL-roof", "power_w", "10 W"],
    ),
    (
        "greedy-require-over-budget",
        ["greedy", *T, *E, *Q, "--budget", "5000", "--include", "LRL-roof"],
        2,
        ["--include LRL-roof", "--budget"],
    ),
    (
        "greedy-require-and-exclude",
        ["greedy", *T, *E, *Q, "--budget", "5000", "--include", "HD2K-3", "--exclude", "HD2K-3"],
        2,
        ["--include", "--exclude", "HD2K-3"],
    ),
    (
        "greedy-owned-without-require",
        ["greedy", *T, *E, *Q, "--budget", "5000", "--owned"],
        2,
        ["--owned", "--include"],
    ),
    ("greedy-max-sensors-zero", ["greedy", *T, *E, *Q, "--budget", "5000", "--max-sensors", "0"], 2, ["--max-sensors"]),
    (
        "greedy-limits-buy-nothing",
        ["greedy", *T, *E, *Q, "--budget", "5000", "--limit", "power_w=0.1"],
        2,
        ["nothing can be bought", "power_w"],
    ),
    ("score-limit-unknown-resource", ["score", *T, *E, "--suite", "LRL-roof", "--limit", "heat_w=5"], 2, ["heat_w"]),
    (
        "pareto-require-over-limit",
        ["pareto", *T, *E, *Q, "--include", "LRL-roof", "--limit", "power_w=10", "--output-dir", "{d}/p"],
        2,
        ["--include LRL-roof", "power_w"],
    ),
    (
        "resilient-limit-unknown-resource",
        ["resilient", *T, *E, *Q, "--budget", "5000", "--limit", "heat_w=5", "--output-dir", "{d}/r"],
        2,
        ["heat_w"],
    ),
    (
        "robust-require-over-limit",
        ["robust", *T, *E, *Q, "--budget", "110000", "--include", "LRL-roof,MRL-roof", "--limit", "power_w=50"],
        2,
        ["--include LRL-roof,MRL-roof", "68 W", "power_w"],
    ),
    (
        "optimal-require-over-max-sensors",
        ["optimal", *T, *E, *Q, "--budget", "110000", "--include", "LRL-roof,MRL-roof", "--max-sensors", "1"],
        2,
        ["--include", "--max-sensors"],
    ),
    (
        "certify-result-with-limits",
        ["certify", *T, *E, *Q, "--suite", "{d}/g.json", "--limit", "power_w=100"],
        2,
        ["--suite", "--limit"],
    ),
    # ---- study
    ("study-missing-file", ["study", "{d}/missing.yaml", "--output-dir", "{d}/st"], 2, ["missing.yaml"]),
    ("study-unknown-key", ["study", "{d}/study_key.yaml", "--output-dir", "{d}/st"], 2, ["study_key.yaml", "colours"]),
    (
        "study-bad-budget",
        ["study", "{d}/study_budget.yaml", "--output-dir", "{d}/st"],
        2,
        ["study_budget.yaml", "lots"],
    ),
]


def test_the_catalogue_is_large_and_covers_every_command():
    assert len(CASES) >= 60 and len({c[0] for c in CASES}) == len(CASES)
    commands = {c[1][0] for c in CASES}
    assert commands == {
        "library",
        "score",
        "scene",
        "landmarks",
        "greedy",
        "pareto",
        "resilient",
        "certify",
        "optimal",
        "simulate",
        "robust",
        "study",
    }


@pytest.mark.parametrize("name, args, status, fragments", CASES, ids=[c[0] for c in CASES])
def test_bad_input(files, name, args, status, fragments):
    r = _invoke([a.replace("{d}", str(files)) for a in args])
    out = r.output
    assert r.exit_code == status, (r.exit_code, out, r.exception)
    assert "Traceback" not in out
    for f in fragments:
        assert f in out, (f, out)
    if status == 2 and "Usage:" not in out:
        errors = [line for line in out.splitlines() if line.startswith("sensorsel: error: ")]
        assert len(errors) == 1, out


def test_simulate_forced_result_without_fingerprint_runs_with_a_warning(files, tmp_path):
    r = _invoke(
        [
            "simulate",
            *T,
            *Q,
            "--suite",
            files / "g_old.json",
            "--force",
            "--runs",
            "1",
            "--jobs",
            "1",
            "--output-dir",
            tmp_path / "s",
        ]
    )
    assert r.exit_code == 0, r.output
    assert "sensorsel: warning:" in r.output and "g_old.json" in r.output and "Traceback" not in r.output


def test_resume_with_another_landmark_map_recomputes_and_says_what_differs(tmp_path):
    base = ["resilient", *T, *E, *Q, "--budget", "20000", "--failures", "1", "--output-dir", tmp_path / "r"]
    assert _invoke(base).exit_code == 0
    r = _invoke([*base, "--resume", "--landmarks", "synthetic"])
    assert r.exit_code == 0, r.output
    assert "sensorsel: warning:" in r.output and "not reused" in r.output and "another landmark map" in r.output
    assert "Traceback" not in r.output
