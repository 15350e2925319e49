"""The fast engine: the reference's log det of every suite, without rebuilding or relinearizing.

The numbers are the reference's (GTSAM: build, linearize at the truth, eliminate) to round-off:
measured ~1e-14 relative on the fixtures and KITTI 03/00, tested to 1e-9 on every evaluation.

Method
------
1. Linearize once. The linearization point is the truth, so a measurement's information never
   changes. :func:`sensorsel.information.linearize.linearize_library` linearizes every distinct (keyframe,
   landmark) pair that some sensor measures (unit noise) and the base graph (first-pose prior,
   odometry, landmark priors), in closed form: GTSAM's Jacobians of those factors at the truth,
   written out (tested against GTSAM's linearization). A suite's information is then
   ``Λ(S) = Λ₀ + Σ_pairs Σ_{r ∈ bearing, range} ω_r h_r h_rᵀ`` where ``h_r`` is the pair's Jacobian row
   and ``ω_r`` the sum of 1/σ_r² over the suite's sensors that measure the pair: a suite is a vector
   of pair weights, and adding a sensor adds its own weights.
2. Landmarks are conditionally independent given the poses. With ``D_j`` the 2×2 information of
   landmark j and ``W_j`` its coupling to the keyframes,
   ``log det Λ = Σ_j log det D_j + log det P``, ``P = Λ_pp − Σ_j W_j D_j⁻¹ W_jᵀ`` (3K × 3K).
3. P is dense on real routes. On KITTI 00 with the 120 m LiDAR in the suite each landmark is seen
   from ~75 keyframes over 2-3 passes of the loops, ~50% of P's 3×3 pose blocks are non-zero and a
   fill-reducing (minimum degree) order still leaves ~50% of a dense factorization's work. So P is
   factored by LAPACK's dense Cholesky (dpotrf at ~peak speed), unless fewer than
   :data:`SPARSE_BELOW` of its blocks are non-zero (e.g. one narrow radar or camera alone, the first
   greedy step), where SuperLU with a minimum-degree order is 2-3x faster (measured per sensor on 00).
3b. Or the whole matrix, frontally (:mod:`.front`). At a fixed route P's non-zero blocks
   per row grow with the keyframe rate (a keyframe is coupled to every keyframe within sensor
   range), so the dense factorization costs K³. Instead the full information matrix (poses and
   landmarks) is eliminated chunk by chunk of keyframes in a keyframe order (route order, x or y
   sweep, or RCM of nearby keyframes: whichever is predicted cheapest for the suite), each chunk's
   poses together with the variables seen for the last time, the Schur complement on the
   still-open variables carried on: ~3 (2F)² flops per keyframe with F the open landmarks, linear
   in the route. The kernel takes it when its predicted flops are below :data:`FRONT_BELOW` of the
   dense Cholesky's (measured crossover ~1x: the dense path also pays the Schur assembly below).
4. Assembly. ``Σ_j W_j D_j⁻¹ W_jᵀ = Σ_j Y_j Y_jᵀ`` with ``Y_j = W_j L_j⁻ᵀ`` (``D_j = L_j L_jᵀ``).
   Landmarks are grouped in route order (:data:`GROUP_SIZE` per group: neighbours on the road are
   seen from the same keyframes on every pass). Each group's Y is a dense tile whose rows are the
   keyframes that see the group, as runs of consecutive keyframes; one BLAS syrk/gemm per pair of
   runs accumulates ``tile tileᵀ`` straight into P's lower triangle (scipy's BLAS through its
   Cython function pointers, with a leading dimension: no temporary and no second pass over memory).
5. Incremental candidates. :meth:`FastEvaluator.scores_with` computes the base suite's pair
   weights, landmark and pose sums and the W of its measured pairs once; each candidate adds its
   own few thousand pairs to copies and reuses the base's tile layout unless it measures pairs the
   base does not (radars reaching beyond the LiDAR), which get a layout of their own.

Why not a low-rank update (determinant lemma) of the base: a candidate's update has rank 2 per
measurement (2,000-11,000 measurements per camera or radar on 00), and in the pose space it reaches
every keyframe: with the LiDAR in the suite, each later candidate changes 750-1,550 landmarks, seen
from all 455 keyframes. Every lemma form (pose space, landmark space, full space) is larger than
the 1,365 × 1,365 pose matrix itself, so factoring P is the cheapest exact step.

Parallelism: candidates are scored on ``jobs`` threads (from :data:`THREADS_FROM_KEYFRAMES` on:
smaller problems are quicker on one). numpy's array code and the ctypes BLAS
calls release the GIL; threads share the linearized problem without pickling (a linearized GTSAM
graph does not pickle) and without fork (forked workers after multithreaded BLAS were seen to
hang, see the shared GTSAM notes). BLAS is held at one thread per caller while scoring (threadpoolctl): its
threaded Cholesky splits work by thread count (results could differ in the last bits) and its
spinning threads were measured 10-20x slower on the busy 2-core machine. Every candidate's number
comes from the same code on the same inputs, so results are identical whatever ``jobs`` is.

Modules: :mod:`.plan` (landmark groups, keyframe runs, BLAS calls), :mod:`.state` (a suite's pair
weights and sums, built once per base suite), :mod:`.kernel` (Schur complement and factorization),
:mod:`.blas` (BLAS/LAPACK function pointers, thread control), :mod:`.front` (the frontal path),
:mod:`.bound` (upper bounds on candidates' gains from a base suite's covariance, for the lazy
greedy), :mod:`.evaluator` (FastEvaluator).
"""

from __future__ import annotations

from sensorsel.information.evaluators.fast.evaluator import THREADS_FROM_KEYFRAMES, FastEvaluator
from sensorsel.information.evaluators.fast.front import CHUNK_POSES
from sensorsel.information.evaluators.fast.kernel import FRONT_BELOW, SPARSE_BELOW, Kernel
from sensorsel.information.evaluators.fast.plan import GROUP_SIZE, RUN_GAP

__all__ = [
    "FastEvaluator",
    "Kernel",
    "THREADS_FROM_KEYFRAMES",
    "SPARSE_BELOW",
    "FRONT_BELOW",
    "CHUNK_POSES",
    "GROUP_SIZE",
    "RUN_GAP",
]
