"""A design study: one target, a grid of settings, one run per cell (``sensorsel study FILE.yaml --output-dir DIR``).

A study file is YAML (read safely, a key repeated in one mapping refused; every error names the
file, the key path and the line, like an operating-domain file)::

    target:                        # what every cell runs on: one route ...
      fixture: tiny                #   fixture, seq (+ kitti_root) or route (+ format, times), as a domain's route
      landmarks: synthetic         #   real, synthetic, {synthetic: {seed: N}} or a landmark CSV
      rate: 1.0                    #   keyframes per second (default 1)
      clearance_m: 3.0             #   optional: drop landmarks closer than this to the route
      # domain: domain.yaml        # ... or an operating domain (instead of the keys above),
      # aggregate: normalised      #     its routes combined as `--aggregate` does (normalised or raw)
    grid:                          # the cells: every combination, one run each
      budgets: [5000, "$12,000"]   # required; dollars (a number, or text such as "$110,000")
      rules: [uniform, best-of]    # greedy rules (default [uniform])
      failures: [0, 1]             # sensors that may fail, alpha (default [0])
      landmark_seeds: [0, 1]       # seeds of the synthetic map (needs target.landmarks: synthetic)
      libraries: [default, reduced_library.yaml]   # sensor libraries; default: Table I (a domain: its own)
    engine: fast                   # optional: the scoring engine
    method: algorithm-2            # how a cell with failures > 0 chooses: algorithm-2 or robust
    certificate: true              # alpha = 0 cells: the certificate's "at least X% of the best" (default true)

Relative paths are relative to the study file's folder.

**A cell** is one (library, landmark seed, failures, rule, budget); cells are numbered in that
order, the budget varying fastest. A cell with 0 failures is a greedy run (and its certificate:
at most one sweep of the library per pick). A cell with alpha > 0 failures runs, by default, the
paper's Algorithm 2 with the cell's rule (:func:`sensorsel.designs.resilient.resilient_select`: the alpha
sensors with the best single scores assumed to fail, the rest of the budget spent greedily), and
scores the suite's exact worst case; Algorithm 2 is chosen as the default because it is a fixed,
bounded amount of work per cell (two greedy runs and C(|S|, alpha) evaluations), so a grid's cost
is predictable. ``method: robust`` runs :func:`sensorsel.designs.robust.robust_select` instead (greedy with
the cell's rule, Algorithm 2 and further methods, the best exact worst case kept, with an upper
bound: its row's certificate is the worst case as a percentage of that bound), at a cost that
depends on the bound's search.

**Results**: one :class:`StudyRow` per cell (settings, suite, cost, score, worst case, certificate,
evaluations, seconds), in cell order, whatever order the cells finished in. :func:`run_study` runs
the cells as a plan (:func:`cell_plan`) through an executor (:mod:`sensorsel.pipeline`: in this
process, or one Dask task per cell); the rows are the same bytes (timings aside). With ``outdir``, each
finished cell is written to ``OUTDIR/cells/cell-KEY.json`` as it finishes (atomically; KEY a digest
of the cell's settings), with a fingerprint of everything the cell depends on (the target by
content, library, seed, budget, rule, failures, method, engine, aggregate, laziness, certificate);
``resume`` reads back the cells whose fingerprint matches instead of running them again.
"""

from __future__ import annotations

from sensorsel.designs.study.parsing import load_study, parse_study
from sensorsel.designs.study.records import (
    DEFAULT_LIBRARY,
    FORMAT,
    METHODS,
    Cell,
    Study,
    StudyCellRecord,
    StudyError,
    StudyResult,
    StudyRow,
    StudyTarget,
    TargetFiles,
)
from sensorsel.designs.study.run import (
    CSV_COLUMNS,
    CellTask,
    cell_file,
    cell_fingerprint,
    cell_plan,
    cell_step,
    run_cell,
    run_study,
    study_csv,
    write_study,
)

__all__ = [
    "Cell",
    "DEFAULT_LIBRARY",
    "FORMAT",
    "METHODS",
    "Study",
    "StudyCellRecord",
    "StudyError",
    "StudyResult",
    "StudyRow",
    "StudyTarget",
    "TargetFiles",
    "load_study",
    "parse_study",
    "CSV_COLUMNS",
    "CellTask",
    "cell_file",
    "cell_fingerprint",
    "cell_plan",
    "cell_step",
    "run_cell",
    "run_study",
    "study_csv",
    "write_study",
]
