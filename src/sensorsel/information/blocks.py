"""Copies of blocks of a covariance matrix: ``P[rows][:, cols]`` as a new array, the same numbers as
numpy's ``P[np.ix_(rows, cols)]``, cheaper where the rows and columns run in a few stretches of
consecutive indices (the filter's dormant landmarks, :mod:`~sensorsel.information.filtering`)."""

from __future__ import annotations

import numpy as np

__all__ = ["BLOCK_PIECES", "BLOCK_SLICED_FROM", "block", "stretches"]

#: a block of at least this many elements is copied by slices where its rows and columns run in a
#: few stretches (:func:`block`)
BLOCK_SLICED_FROM = 1 << 16
#: the most (row stretch, column stretch) pieces a block is copied in
BLOCK_PIECES = 64


def block(P: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """P[rows][:, cols], a new array (the same numbers as ``P[np.ix_(rows, cols)]``). A large block
    whose rows and columns run in a few stretches of consecutive indices (a window's dormant
    landmarks: mostly those that came first, held in the order they came) is copied a stretch by a
    stretch, as slices; else by two takes (~2/3 of ``np.ix_``'s time). On a user's drive the
    dormant blocks of ~1,000 rows ran in 1 to 4 stretches, where the takes cost 4-6 ms each."""
    if len(rows) * len(cols) < BLOCK_SLICED_FROM:
        return P.take(rows, axis=0).take(cols, axis=1)
    row_runs, col_runs = stretches(rows), stretches(cols)
    if len(row_runs) * len(col_runs) > BLOCK_PIECES:
        return P.take(rows, axis=0).take(cols, axis=1)
    out = np.empty((len(rows), len(cols)))
    for at, lo, hi in row_runs:
        for to, left, right in col_runs:
            out[at : at + hi - lo, to : to + right - left] = P[lo:hi, left:right]
    return out


def stretches(index: np.ndarray) -> list[tuple[int, int, int]]:
    """The runs of consecutive values in ``index`` (n,): (where each begins in ``index``, its first
    value, past its last)."""
    index = np.asarray(index, np.int64)
    begins = np.concatenate([[0], np.flatnonzero(np.diff(index) != 1) + 1]).tolist()
    ends = [*begins[1:], len(index)]
    return [(b, int(index[b]), int(index[b]) + e - b) for b, e in zip(begins, ends, strict=True)]
