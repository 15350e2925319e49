"""Frames found, not assumed: the ground plane and the forward axis of a 3-D route.

A route file gives positions p_i (N, 3) [m] in a world frame and, usually, rotations R_i (N, 3, 3)
that take body coordinates into it. Nothing says which world axis is up (KITTI's camera frames have
y down, a ROS ``map`` frame z up, a survey any rigid motion of either) nor which body axis points
ahead (a camera's z, a vehicle's x). :func:`find_frame` finds both:

- **up** (the ground plane's normal, world frame): the common axis of the relative rotations
  R_i R_0^T (a car on the ground turns about the vertical), checked against the plane the positions
  span (their smallest principal axis); either alone when only one is defined (a straight drive has
  no turn, positions alone have no rotations). The two must agree within :data:`AGREE_DEG`.
- **forward** (body frame): the mean direction of travel in body coordinates, R_i^T v_i / |v_i|.
- An axis found within :data:`SNAP_DEG` of a coordinate axis is taken as that axis exactly, so an
  axis-aligned file gives the very numbers of its planar equivalent (a KITTI file: bit for bit the
  projection sensorsel always used). Under any other rigid motion the ground plane is that of the
  first pose's body (R_0 times its up axis), which is what KITTI's own frame-0 convention means.
- Up and down cannot be told apart from motion on a plane (a mirrored route drives the same
  rotations); the sign follows the body's conventions: a body whose z points forward is a camera
  (x right, y down), any other body has z up (x forward, y left). ``--up``/``--forward`` state them.

The planar frame: right-handed seen from above (X, Y, heading counter-clockwise from X). For an
axis-aligned up it is the file's own pair of axes (z up: X = x, Y = y; y down: X = z, Y = -x, as
KITTI), else X = the first pose's forward projected on the plane. 3-D landmark maps (x, y, z, in the
route's world frame) are projected by the same frame (:meth:`Frame.project`).

Positions-only routes (no rotations) get their heading from the direction of travel
(:func:`headings_from_travel`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sensorsel.errors import InputError, ScenarioError
from sensorsel.model.angles import wrap_angle

MIN_TRAVEL_M = 1.0  # a route whose positions stay within this of each other never moves: refused
SNAP_DEG = 15.0  # an axis found this close to a coordinate axis is taken as that axis (KITTI's own drift: <= 8.2 deg)
AGREE_DEG = 20.0  # the positions' plane and the rotations' common axis must agree within this
PLANE_MIN_M = 2.0  # the positions span a plane when their second principal spread is at least this [m] ...
PLANE_FLAT = 0.25  # ... and their third is at most this fraction of the second
TURN_MIN_DEG = 10.0  # the rotations define a common axis when the route turns at least this much ...
TURN_AXIS_RATIO = 20.0  # ... about one axis this many times more than about any other
FORWARD_MIN = 0.5  # a body axis is the forward one when the mean cosine of the travel with it is at least this ...
FORWARD_MARGIN = 0.5  # ... and it beats the format's own forward axis by this much (else the format's axis stays)
HEADING_WINDOW_M = 4.0  # headings from positions: the chord over this much route, centred on the point [m]
STOP_M = 1e-6  # a step shorter than this is a stop (the heading is kept)
DEGREE_SPREAD_M = 5.0  # numbers inside +-180/+-90 that spread less than this look like degrees
#: a route that moves less than MIN_TRAVEL_M looks like degrees only when it spans less than this
#: (5.5 km of latitude; a hand-held recording of 0.7 m is metres that moved too little, not 77 km in degrees)
DEGREE_ROUTE_SPREAD = 0.05
REVERSAL_MIN_M = 0.5  # a reversal of the direction of travel counts when the car goes back at least this far

_AXES = "xyz"
# planar (X, Y) world axes for an up along a world axis: (index, sign) each, X x Y = up
_PLANE_OF_UP: dict[tuple[int, int], tuple[tuple[int, int], tuple[int, int]]] = {
    (2, 1): ((0, 1), (1, 1)),
    (2, -1): ((0, 1), (1, -1)),
    (1, -1): ((2, 1), (0, -1)),
    (1, 1): ((2, 1), (0, 1)),
    (0, 1): ((1, 1), (2, 1)),
    (0, -1): ((1, 1), (2, -1)),
}


def parse_axis(text: str, option: str) -> tuple[int, int]:
    """An axis as a user writes it: ``z``, ``+z``, ``-y`` (any case) -> (index 0..2, sign +-1)."""
    s = str(text).strip().lower()
    sign = -1 if s.startswith("-") else 1
    name = s.lstrip("+-")
    if len(s) - len(name) > 1 or name not in ("x", "y", "z"):
        raise InputError(f"{option} {text!r}: expected an axis x, y or z with an optional sign (+z, -y)")
    return _AXES.index(name), sign


def axis_name(axis: tuple[int, int]) -> str:
    return ("-" if axis[1] < 0 else "+") + _AXES[axis[0]]


def _unit(v: np.ndarray) -> np.ndarray:
    return np.asarray(v, dtype=float) / float(np.linalg.norm(v))


def _vec(axis: tuple[int, int]) -> np.ndarray:
    v = np.zeros(3)
    v[axis[0]] = axis[1]
    return v


def _snap(v: np.ndarray, deg: float = SNAP_DEG) -> tuple[int, int] | None:
    """The coordinate axis within ``deg`` of unit vector ``v``, or None."""
    k = int(np.argmax(np.abs(v)))
    return (k, 1 if v[k] > 0 else -1) if abs(v[k]) >= math.cos(math.radians(deg)) else None


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """Angle between two lines (sign ignored) [deg]."""
    return math.degrees(math.acos(min(1.0, abs(float(a @ b)) / float(np.linalg.norm(a) * np.linalg.norm(b)))))


def _describe(v: np.ndarray, word: str) -> str:
    ax = _snap(v, 1e-6)
    if ax is not None:
        return f"{_AXES[ax[0]]} {word if ax[1] > 0 else {'up': 'down', 'forward': 'backward'}[word]}"
    return f"{word} ({v[0]:.3f}, {v[1]:.3f}, {v[2]:.3f})"


@dataclass(frozen=True, eq=False)
class Frame:
    """The ground plane and the body's forward axis of a 3-D route.

    Attributes:
        up: (3,) unit normal of the ground plane, world frame (pointing up).
        ex, ey: (3,) unit planar X and Y axes, world frame (ex x ey = up).
        forward: (3,) unit forward axis of the body, body frame (None for positions only).
        body_up: (3,) unit up axis of the body, body frame (None for positions only).
        found: how each was found, for the note.
    """

    up: np.ndarray
    ex: np.ndarray
    ey: np.ndarray
    forward: np.ndarray | None = None
    body_up: np.ndarray | None = None
    found: str = ""

    @property
    def describe(self) -> str:
        """The frame in words: ``camera frame: y down, z forward`` or ``z up; body: x forward``."""
        up = _describe(self.up, "up")
        if self.forward is None:
            return f"ground plane: {up}"
        fwd = _describe(self.forward, "forward")
        name = "camera frame" if _snap(self.forward, 1e-6) in ((2, 1), (2, -1)) else "vehicle frame"
        if self.body_up is None or float(self.up @ self.body_up) > 1 - 1e-12:  # the body's axes are the world's
            return f"{name}: {up}, {fwd}"
        return f"world {up}; body ({name}): {_describe(self.body_up, 'up')}, {fwd}"

    def project(self, points: np.ndarray) -> np.ndarray:
        """World points (M, 3) [m] -> planar (M, 2) [m]; exact selection for an axis-aligned up."""
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        sx, sy = _snap(self.ex, 1e-9), _snap(self.ey, 1e-9)
        if sx is not None and sy is not None:
            return np.column_stack([_pick(p, sx), _pick(p, sy)])
        return np.column_stack([p @ self.ex, p @ self.ey])

    def planar(self, positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        """Planar poses (N, 3): x [m], y [m], heading [rad] of the body's forward axis projected on
        the ground plane, counter-clockwise from planar X."""
        assert self.forward is not None
        xy = self.project(positions)
        fb = _snap(self.forward, 1e-9)
        d = (
            rotations[:, :, fb[0]]
            if fb is not None and fb[1] > 0
            else (-rotations[:, :, fb[0]] if fb is not None else rotations @ self.forward)
        )
        hxy = self.project(d)
        return np.column_stack([xy, np.arctan2(hxy[:, 1], hxy[:, 0])])


def _pick(p: np.ndarray, axis: tuple[int, int]) -> np.ndarray:
    return p[:, axis[0]] if axis[1] > 0 else -p[:, axis[0]]


def _frame_of(up: np.ndarray, first_forward: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Planar X, Y for this up: the file's own pair of axes when up is a world axis, else X = the
    first forward direction projected on the plane (or world x, y)."""
    ax = _snap(up, 1e-9)
    if ax is not None:
        (i, si), (j, sj) = _PLANE_OF_UP[ax]
        return _vec((i, si)), _vec((j, sj))
    cands = ([first_forward] if first_forward is not None else []) + [np.eye(3)[0], np.eye(3)[1]]
    for c in cands:
        x = c - (c @ up) * up
        if np.linalg.norm(x) > 0.1:
            ex = _unit(x)
            return ex, np.cross(up, ex)
    raise AssertionError("unreachable: x and y cannot both be along up")


def check_moves(xy: np.ndarray, path: str | Path) -> float:
    """The route's extent [m] (largest coordinate spread); ScenarioError when below :data:`MIN_TRAVEL_M`
    (a car that never moves), or when its positions look like degrees (:func:`check_not_degrees`)."""
    p = np.asarray(xy, dtype=float)
    extent = float(np.ptp(p, axis=0).max()) if len(p) else 0.0
    if extent < MIN_TRAVEL_M:
        if extent < DEGREE_ROUTE_SPREAD:  # a drive in degrees spans less than a metre too: say which
            check_not_degrees(p, path, "positions")
        raise ScenarioError(
            path,
            f"the car never moves: its {len(p)} positions stay within {extent:.3g} m of each other "
            f"(at least {MIN_TRAVEL_M:g} m of travel is needed to tell the ground plane and the heading; "
            "a hand-held or indoor recording?)",
        )
    return extent


def check_not_degrees(xy: np.ndarray, path: str | Path, what: str, route_extent_m: float | None = None) -> None:
    """Refuse numbers that look like degrees (longitude, latitude) in a metric file: all inside
    +-180 / +-90 (either order), away from 0, spread less than :data:`DEGREE_SPREAD_M` (for a
    landmark map: while the route spans more than 20 times that)."""
    p = np.asarray(xy, dtype=float)[:, :2]
    if not len(p):
        return
    spread = float(np.ptp(p, axis=0).max())
    lim = np.array([180.0, 90.0])
    inside = bool((np.abs(p) <= lim).all() or (np.abs(p) <= lim[::-1]).all())
    away = bool((np.abs(p).max(axis=1) > 1.0).all())
    if not (inside and away and 0.0 < spread < DEGREE_SPREAD_M):
        return
    if route_extent_m is not None and route_extent_m < 20 * DEGREE_SPREAD_M:
        return
    beside = f" while the route spans {route_extent_m:,.0f} m" if route_extent_m is not None else ""
    raise ScenarioError(
        path,
        f"the {what} look like degrees, not metres: every value inside +-180/+-90 (first {p[0, 0]:g}, {p[0, 1]:g}) "
        f"and all within {spread:.3g} m of each other{beside}; sensorsel reads metres: convert them, or give "
        "latitude/longitude as a GPX track or an OpenStreetMap extract (docs/scenarios.md)",
    )


def find_frame(
    positions: np.ndarray,
    rotations: np.ndarray | None,
    path: str | Path,
    *,
    convention: str,
    up: str | None = None,
    forward: str | None = None,
) -> tuple[Frame, list[str]]:
    """The ground plane and forward axis of a route (see the module's docstring).

    Args:
        positions: (N, 3) world positions [m].
        rotations: (N, 3, 3) body-to-world rotations, or None (positions only).
        path: the file, named in errors and notes.
        convention: the format's own frame, ``"camera"`` (KITTI: y down, z forward) or ``"z-up"``
            (TUM, ROS: z up, x forward): no note when the frame found is it.
        up: ``--up`` (a world axis, e.g. ``+z``, ``-y``); forward: ``--forward`` (a body axis).
    Returns:
        (frame, notes).
    Raises:
        ScenarioError: a car that never moves; a straight line without rotations and without ``up``;
            positions and rotations that disagree on the ground plane; no forward axis.
        InputError: a bad ``up``/``forward``, or one along the other.
    """
    P = np.asarray(positions, dtype=float).reshape(-1, 3)
    R = None if rotations is None else np.asarray(rotations, dtype=float).reshape(-1, 3, 3)
    check_moves(P, path)
    conv_up, conv_fwd = ((1, -1), (2, 1)) if convention == "camera" else ((2, 1), (0, 1))
    given_up = parse_axis(up, "--up") if up is not None else None
    given_fwd = parse_axis(forward, "--forward") if forward is not None else None
    how: list[str] = []

    # -- the positions' plane
    c = P - P.mean(axis=0)
    w, V = np.linalg.eigh(c.T @ c / len(P))
    s = np.sqrt(np.maximum(w, 0.0))  # principal spreads, ascending [m]
    n_pos = V[:, 0] if (s[1] >= PLANE_MIN_M and s[0] <= PLANE_FLAT * s[1]) else None
    line_dir = V[:, 2]
    # -- the rotations' common axis
    n_rot = None
    if R is not None:
        A = R @ R[0].T
        turn = np.degrees(np.arccos(np.clip((np.trace(A, axis1=1, axis2=2) - 1) / 2, -1, 1))).max()
        E = A - np.eye(3)
        we, Ve = np.linalg.eigh(np.einsum("nij,nik->jk", E, E))
        if turn >= TURN_MIN_DEG and we[1] >= TURN_AXIS_RATIO * max(we[0], 1e-300):
            n_rot = Ve[:, 0]

    if given_up is not None:
        n_est: np.ndarray | None = _vec(given_up)
        how.append("up as given (--up)")
    elif n_rot is not None and n_pos is not None:
        ang = _angle_deg(n_rot, n_pos)
        if ang > AGREE_DEG:
            raise ScenarioError(
                path,
                f"cannot tell the ground plane: the positions span a plane {ang:.0f} deg from the axis the "
                "rotations turn about (a hilly or tilted route, or positions and rotations in different frames?): "
                "state the up axis (--up +z, --up -y, ...)",
            )
        n_est = n_rot
        how.append(f"ground plane from the rotations' common axis, {ang:.1f} deg from the positions' plane")
    elif n_rot is not None:
        n_est = n_rot
        how.append("ground plane from the rotations' common axis (the positions lie along a line)")
    elif n_pos is not None:
        n_est = n_pos
        how.append("ground plane from the positions" + (" (the route does not turn)" if R is not None else ""))
    else:
        n_est = None

    if R is None:
        if n_est is None:
            raise ScenarioError(
                path,
                f"cannot tell the ground plane: the positions lie along a straight line ({s[2]:.0f} m long, "
                f"{s[1]:.2g} m across) and the file has no rotations: state the up axis (--up +z, --up -y, ...)",
            )
        ax = _snap(n_est)
        if given_up is not None:
            n = n_est
        elif ax is not None:
            # the sign: z up (a map, a GPS log), y down (a camera frame), else +
            sign = {2: 1, 1: -1}.get(ax[0], 1)
            n = _vec((ax[0], sign))
        else:
            n = n_est if n_est[2] >= 0 else -n_est
            how.append("the up side taken as the one towards +z (--up states it)")
        ex, ey = _frame_of(n, None)
        frame = Frame(n, ex, ey, None, None, "; ".join(how))
        notes = [] if _snap(n, 1e-9) == (2, 1) else [f"route {path}: {frame.describe} ({frame.found})"]
        return frame, notes

    # -- the body's forward axis: the mean direction of travel in body coordinates
    v = np.gradient(P, axis=0)
    sp = np.linalg.norm(v, axis=1)
    moving = sp > STOP_M
    weak_forward = False
    if given_fwd is not None:
        f_b = _vec(given_fwd)
        how.append("forward as given (--forward)")
    else:
        b = np.einsum("nji,nj->ni", R[moving], v[moving] / sp[moving, None])  # unit travel, body frame
        score = np.concatenate([b.mean(axis=0), -b.mean(axis=0)])  # mean cos with +x, +y, +z, -x, -y, -z
        best = int(np.argmax(score))
        best_axis = (best % 3, 1 if best < 3 else -1)
        conv_score = float(score[conv_fwd[0] + (0 if conv_fwd[1] > 0 else 3)])
        if best_axis != conv_fwd and score[best] >= FORWARD_MIN and score[best] - conv_score >= FORWARD_MARGIN:
            f_b = _vec(best_axis)
            back = float(np.mean(b[:, best_axis[0]] * best_axis[1] < 0))
            how.append(
                f"forward: body {axis_name(best_axis)}, the axis along the direction of travel (mean cos "
                f"{score[best]:.2f}; "
                f"the format's {axis_name(conv_fwd)}: {conv_score:.2f})"
                + (f"; drives backwards for {100 * back:.0f}% of the route" if back > 0.01 else "")
            )
        else:
            f_b = _vec(conv_fwd)
            weak_forward = conv_score < FORWARD_MIN
            if weak_forward:
                how.append(
                    "no body axis points clearly along the direction of travel (mean cos with the format's "
                    f"{axis_name(conv_fwd)}: "
                    f"{conv_score:.2f}): forward taken as {axis_name(conv_fwd)} (--forward states it)"
                )

    # -- the body's up axis and the world's
    if n_est is None:
        # a straight drive that does not turn: the format's convention, checked against the line
        u_b = _vec(conv_up) if given_fwd is None or abs(_vec(conv_up) @ f_b) < 0.5 else _vec(_other_up(f_b))
        n_w = R[0] @ u_b
        if abs(float(n_w @ line_dir)) > math.sin(math.radians(AGREE_DEG)):
            raise ScenarioError(
                path,
                f"cannot tell the ground plane: the route is a straight line ({s[2]:.0f} m) that does not turn, "
                f"and the format's convention ({'camera frame: y down' if convention == 'camera' else 'z up'}) "
                "does not fit it: state the up axis (--up +z, --up -y, ...)",
            )
        how.append("the route neither turns nor leaves a line: up from the format's convention, which fits it")
    else:
        raw = np.einsum("nji,j->ni", R, n_est).mean(axis=0)  # the body axis along n_est, on average
        if np.linalg.norm(raw) < 0.5:
            raise ScenarioError(
                path,
                "cannot tell the body's up axis: the rotations do not keep one body axis along the ground "
                "plane's normal: state the axes (--up, --forward)",
            )
        u_raw = _unit(raw)
        if abs(float(u_raw @ f_b)) > math.sin(math.radians(90 - AGREE_DEG)):
            raise ScenarioError(
                path,
                f"the forward axis found ({np.round(f_b, 3).tolist()}) is not level: it is "
                f"{90 - math.degrees(math.acos(min(1.0, abs(float(u_raw @ f_b))))):.0f} deg from the ground plane: "
                "state the axes (--up, --forward)",
            )
        uax = _snap(u_raw)
        u_b = _vec(uax) if uax is not None else u_raw
        if given_up is not None:
            u_b = u_b if float(np.einsum("nij,j->ni", R, u_b).mean(axis=0) @ n_est) > 0 else -u_b
        else:
            u_b = _signed_body_up(u_b, f_b)
        n_w = _unit(np.einsum("nij,j->ni", R, u_b).mean(axis=0))
    wax = _snap(n_w)
    if given_up is not None:
        n = _vec(given_up)
    elif wax is not None:
        n = _vec(wax)
    else:
        n = _unit(R[0] @ u_b)  # the first pose's ground plane (KITTI's frame-0 convention)
        how.append("ground plane: that of the first pose's body")
    ex, ey = _frame_of(n, R[0] @ f_b)
    frame = Frame(n, ex, ey, f_b, u_b, "; ".join(how))
    conv = _snap(n, 1e-9) == conv_up and _snap(f_b, 1e-9) == conv_fwd and _snap(u_b, 1e-9) == conv_up
    return frame, ([] if conv and not weak_forward else [f"route {path}: {frame.describe} ({frame.found})"])


def _other_up(f_b: np.ndarray) -> tuple[int, int]:
    return (1, -1) if _snap(f_b) in ((2, 1), (2, -1)) else (2, 1)


def _signed_body_up(u_b: np.ndarray, f_b: np.ndarray) -> np.ndarray:
    """The sign of the body's up axis, which motion on a plane cannot tell: a body whose z points
    forward and whose up is along y is a camera (x right, y down: left = up x forward = -x); any
    other body axis is taken pointing up (z up: x forward, y left); an axis off the coordinate
    axes, the sign that makes its largest component positive."""
    fax, uax = _snap(f_b, 1e-9), _snap(u_b, 1e-9)
    if fax is not None and fax[0] == 2 and uax is not None and uax[0] == 1:
        return u_b if np.cross(u_b, f_b)[0] < 0 else -u_b
    k = int(np.argmax(np.abs(u_b)))
    return u_b if u_b[k] > 0 else -u_b


def _spaced(xy: np.ndarray, min_m: float) -> np.ndarray:
    """Indices of the points of ``xy`` (N, 2) each at least ``min_m`` from the previous one kept
    (the first always kept)."""
    keep = [0]
    for i in range(1, len(xy)):
        if math.hypot(*(xy[i] - xy[keep[-1]])) >= min_m:
            keep.append(i)
    return np.asarray(keep, dtype=int)


def headings_from_travel(
    t: np.ndarray, xy: np.ndarray, *, window_m: float = HEADING_WINDOW_M
) -> tuple[np.ndarray, list[str]]:
    """Headings [rad] of a positions-only route, from its direction of travel.

    The heading at point i is that of the chord between the route's points ``window_m / 2`` of
    travel before and after it (interpolated along the path; exact on a straight line and on a
    circle, and it smooths noise over ``window_m``). A stop keeps the last heading (positions that do
    not move have none); the first points before any motion take the first heading. A reversal of
    the direction of travel (a cusp: the chord turns by more than 150 deg within one window) is said
    in a note: a car backing up looks the same as one turning round, and is taken as driving forward.

    Args:
        t: (N,) times [s] (for the notes).
        xy: (N, 2) planar positions [m].
    Returns:
        (headings (N,) [rad] in (-pi, pi], notes).
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    n = len(xy)
    if n < 2:
        return np.zeros(n), []
    seg = np.hypot(*np.diff(xy, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = float(s[-1])
    if total <= STOP_M:
        return np.zeros(n), []
    # the path as a function of travel: the distinct points (a stop repeats one)
    keep = np.concatenate([[True], seg > STOP_M])
    sk, pk = s[keep], xy[keep]
    h = 0.5 * window_m
    lo, hi = np.clip(s - h, 0.0, total), np.clip(s + h, 0.0, total)

    def at(q: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(q, sk, pk[:, 0]), np.interp(q, sk, pk[:, 1])])

    d = at(hi) - at(lo)
    heading = np.arctan2(d[:, 1], d[:, 0])
    # a stop keeps the last heading: a point whose travel equals its predecessor's
    stopped = np.concatenate([[False], seg <= STOP_M])
    for i in np.flatnonzero(stopped):
        heading[i] = heading[i - 1]
    notes: list[str] = []
    # reversals: the direction of travel over one window against the next, between points at least
    # REVERSAL_MIN_M apart (a car at a light whose ground truth rolls back 7 mm does not reverse)
    far = _spaced(xy, REVERSAL_MIN_M)
    dxy = np.diff(xy[far], axis=0)
    step = np.arctan2(dxy[:, 1], dxy[:, 0])
    tm, sm = t[far][1:], s[far][1:]
    if len(step) > 1:
        j = np.searchsorted(sm, sm + window_m)
        j = np.minimum(j, len(step) - 1)
        turn = np.abs(wrap_angle(step[j] - step))
        cusp = np.flatnonzero((turn > math.radians(150)) & (sm[j] - sm <= 1.5 * window_m))
        if len(cusp):
            times = sorted({round(float(tm[k]), 1) for k in cusp})
            notes.append(
                f"the direction of travel reverses near t = {', '.join(f'{x:g}' for x in times[:5])} s"
                f"{' ...' if len(times) > 5 else ''}: taken as turning round; if the car backed up "
                "there, its heading is 180 deg off"
            )
    return heading, notes
