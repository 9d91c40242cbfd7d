"""Toolpaths of direct ink writing: the desired path, waypoint offsets and the nozzle path.

The desired deposition path is parametric, ``p(s)``, 0 <= s <= 1 (thesis eq. 3.41), built
from lines and circular arcs with ``s`` proportional to arc length.  A toolpath is the
desired path with N waypoints moved along its normal (eq. 3.42-3.46)::

    w_i  = p(s_i)                                   waypoints on the path       (3.42)
    n_i  = (dy/ds, -dx/ds) / |dp/ds|  at s_i        the (unit) normal            (3.43)
    w~_i = w_i + delta_i n_i                        offset waypoints             (3.44)
    lambda = [(s_1, delta_1), ..., (s_N, delta_N)]  the parameters               (3.46)

and joined by PCHIP (Fritsch & Carlson 1980, ``scipy.interpolate.PchipInterpolator``),
which does not overshoot between waypoints.  What is interpolated here is the offset
vector: ``p_nozzle(s) = p(s) + D(s)`` with ``D`` the componentwise PCHIP through
``(s_i, delta_i n_i)`` (and through zero at the fixed end waypoints).  So the nozzle path
passes through every w~_i exactly and, with all delta_i = 0, is the desired path itself
(the naive toolpath), corners included; PCHIP through the offset points' x, y alone (the
literal reading of eq. 3.45) would cut every corner that is not a waypoint.

The nozzle moves along ``p_nozzle`` at a constant speed ``v`` (time t = arc length / v);
:class:`Toolpath` has ``position(t)``, ``velocity(t)`` and ``duration``: the path protocol
of :func:`sphfem.diw.extrusion.simulate_deposit` (see :mod:`sphfem.diw`).

Named cases (thesis section 3.4; the thesis gives the nozzle D = 0.7 mm and the offset
bounds, not the path lengths, so the lengths here are ours): ``bend90`` (two legs meeting
at a right angle at the origin), ``bend180-small`` and ``bend180-large`` (two parallel legs
joined by a half circle of radius 2 mm / 5 mm), ``line`` (a straight line, for tests), and
``bend90-corner`` (the 90-degree bend searched with 4 inward offsets at fixed s near the
corner: a smaller search space for small evaluation budgets).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicHermiteSpline, PchipInterpolator

__all__ = [
    "Arc",
    "CASES",
    "DesiredPath",
    "Line",
    "ParameterSpace",
    "Toolpath",
    "WaypointSpec",
    "named_case",
]


# --------------------------------------------------------------------------------------
# primitives: a line segment and a circular arc, each with a local parameter u in [0, 1]


@dataclass(frozen=True)
class Line:
    """Segment from ``a`` to ``b`` [m]."""

    a: tuple[float, float]
    b: tuple[float, float]

    @property
    def length(self) -> float:
        return math.dist(self.a, self.b)

    def point(self, u):
        a, b = np.asarray(self.a), np.asarray(self.b)
        return a + np.multiply.outer(u, b - a)

    def tangent(self, u):
        d = (np.asarray(self.b) - np.asarray(self.a)) / self.length
        return np.broadcast_to(d, np.shape(u) + (2,)).copy()

    def project(self, xy):
        """Closest point: ``(distance, u)`` for points ``xy`` (n, 2)."""
        a, b = np.asarray(self.a), np.asarray(self.b)
        d = b - a
        u = np.clip((xy - a) @ d / (d @ d), 0.0, 1.0)
        return np.linalg.norm(xy - self.point(u), axis=1), u


@dataclass(frozen=True)
class Arc:
    """Circular arc: centre [m], radius [m], start angle [rad], signed sweep [rad]
    (positive: counter-clockwise)."""

    center: tuple[float, float]
    radius: float
    theta0: float
    sweep: float

    @property
    def length(self) -> float:
        return self.radius * abs(self.sweep)

    def point(self, u):
        th = self.theta0 + self.sweep * np.asarray(u, dtype=float)
        return np.stack([self.center[0] + self.radius * np.cos(th),
                         self.center[1] + self.radius * np.sin(th)], axis=-1)

    def tangent(self, u):
        th = self.theta0 + self.sweep * np.asarray(u, dtype=float)
        sgn = math.copysign(1.0, self.sweep)
        return np.stack([-sgn * np.sin(th), sgn * np.cos(th)], axis=-1)

    def project(self, xy):
        """Closest point: ``(distance, u)`` for points ``xy`` (n, 2): the radial foot if its
        angle lies on the arc, else the nearer end point."""
        c = np.asarray(self.center)
        ang = np.arctan2(xy[:, 1] - c[1], xy[:, 0] - c[0])
        u = np.mod((ang - self.theta0) * math.copysign(1.0, self.sweep), 2 * math.pi)
        u = u / abs(self.sweep)
        inside = u <= 1.0
        d_in = np.abs(np.linalg.norm(xy - c, axis=1) - self.radius)
        d0 = np.linalg.norm(xy - self.point(0.0), axis=1)
        d1 = np.linalg.norm(xy - self.point(1.0), axis=1)
        d = np.where(inside, d_in, np.minimum(d0, d1))
        u = np.where(inside, u, np.where(d0 <= d1, 0.0, 1.0))
        return d, u


# --------------------------------------------------------------------------------------
# the desired path


class DesiredPath:
    """A chain of :class:`Line` / :class:`Arc` pieces, parametrised by s in [0, 1]
    proportional to arc length (eq. 3.41)."""

    def __init__(self, pieces: Sequence[Line | Arc], name: str = "path"):
        if not pieces:
            raise ValueError("a path needs at least one piece")
        for p, q in zip(pieces[:-1], pieces[1:], strict=True):
            if not np.allclose(p.point(1.0), q.point(0.0), atol=1e-12):
                raise ValueError(f"{name}: pieces are not joined end to start")
        self.pieces = tuple(pieces)
        self.name = name
        lengths = np.array([p.length for p in pieces])
        self.length = float(lengths.sum())
        #: s at the start of each piece and 1 at the end
        self.breaks = np.concatenate([[0.0], np.cumsum(lengths) / self.length])
        self.breaks[-1] = 1.0

    def _locate(self, s):
        s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
        k = np.clip(np.searchsorted(self.breaks, s, side="right") - 1, 0, len(self.pieces) - 1)
        u = (s - self.breaks[k]) / (self.breaks[k + 1] - self.breaks[k])
        return s, k, u

    def _per_piece(self, s, fn):
        s, k, u = self._locate(s)
        out = np.empty(s.shape + (2,))
        for i, piece in enumerate(self.pieces):
            m = k == i
            if np.any(m):
                out[m] = getattr(piece, fn)(u[m])
        return out

    def point(self, s):
        """p(s) [m], shape ``s.shape + (2,)``."""
        return self._per_piece(s, "point")

    def tangent(self, s):
        """Unit tangent dp/ds / |dp/ds|; at a joint between pieces the normalised mean of
        the two one-sided tangents (the bisector at a corner)."""
        t = self._per_piece(s, "tangent")
        s_arr = np.asarray(s, dtype=float)
        for j, sb in enumerate(self.breaks[1:-1], start=1):
            m = np.isclose(s_arr, sb, rtol=0.0, atol=1e-12)
            if np.any(m):
                mean = self.pieces[j - 1].tangent(1.0) + self.pieces[j].tangent(0.0)
                n = np.linalg.norm(mean)
                t[m] = mean / n if n > 1e-12 else self.pieces[j].tangent(0.0)
        return t

    def normal(self, s):
        """Unit normal n = (dy/ds, -dx/ds) / |dp/ds| (eq. 3.43): to the right of the
        direction of travel."""
        t = self.tangent(s)
        return np.stack([t[..., 1], -t[..., 0]], axis=-1)

    def project(self, xy):
        """Closest point on the path of points ``xy`` (n, 2) [m]: ``(dist, s, offset)`` with
        ``offset`` the signed distance along the normal at s (positive on the right)."""
        xy = np.atleast_2d(np.asarray(xy, dtype=float))[:, :2]
        best_d = np.full(len(xy), np.inf)
        best_s = np.zeros(len(xy))
        for i, piece in enumerate(self.pieces):
            d, u = piece.project(xy)
            better = d < best_d
            best_d[better] = d[better]
            best_s[better] = self.breaks[i] + u[better] * (self.breaks[i + 1] - self.breaks[i])
        offset = np.einsum("ij,ij->i", xy - self.point(best_s), self.normal(best_s))
        return best_d, best_s, offset

    def polyline(self, ds: float) -> np.ndarray:
        """Points along the path at most ``ds`` [m] apart (corners included), (m, 2)."""
        s = [np.linspace(a, b, max(2, math.ceil((b - a) * self.length / ds) + 1))
             for a, b in zip(self.breaks[:-1], self.breaks[1:], strict=True)]
        return self.point(np.unique(np.concatenate(s)))


# --------------------------------------------------------------------------------------
# waypoints and the parameter space of the optimisation


@dataclass(frozen=True)
class WaypointSpec:
    """One waypoint: ``s`` and ``delta`` [m] each either fixed (a float) or free within
    ``(lo, hi)`` (a pair), as in the thesis' tables 3.3-3.5."""

    s: float | tuple[float, float]
    delta: float | tuple[float, float] = 0.0

    def free(self) -> list[tuple[str, tuple[float, float]]]:
        return [(n, v) for n, v in (("s", self.s), ("delta", self.delta))
                if isinstance(v, tuple)]


class ParameterSpace:
    """The optimisation variables lambda (eq. 3.46): the free s_i, delta_i of the waypoints,
    in that order, with their bounds; fixed values are filled in by :meth:`waypoints`."""

    def __init__(self, specs: Sequence[WaypointSpec]):
        self.specs = tuple(specs)
        self.names, lo, hi = [], [], []
        for i, w in enumerate(self.specs, start=1):
            for name, (a, b) in w.free():
                if not a <= b:
                    raise ValueError(f"waypoint {i}: {name} bounds ({a}, {b}) are reversed")
                if name == "s" and not (0.0 <= a and b <= 1.0):
                    raise ValueError(f"waypoint {i}: s bounds ({a}, {b}) outside [0, 1]")
                self.names.append(f"{name}{i}")
                lo.append(a)
                hi.append(b)
        self.lower = np.array(lo, dtype=float)
        self.upper = np.array(hi, dtype=float)

    @property
    def n_var(self) -> int:
        return len(self.names)

    def waypoints(self, x) -> tuple[np.ndarray, np.ndarray]:
        """``(s, delta)`` of every waypoint for the parameter vector ``x`` (clipped to the
        bounds)."""
        x = np.clip(np.asarray(x, dtype=float), self.lower, self.upper)
        if x.shape != (self.n_var,):
            raise ValueError(f"expected {self.n_var} parameters, got shape {x.shape}")
        it = iter(x)  # per waypoint: its free s, then its free delta (as in self.names)
        s, d = [], []
        for w in self.specs:
            s.append(float(next(it)) if isinstance(w.s, tuple) else float(w.s))
            d.append(float(next(it)) if isinstance(w.delta, tuple) else float(w.delta))
        return np.array(s), np.array(d)

    def naive(self) -> np.ndarray:
        """A parameter vector with every free delta = 0 (clipped into its bounds) and s at
        the middle of its bounds: the desired path as toolpath when 0 is allowed."""
        return np.array([0.5 * (a + b) if n.startswith("s") else min(max(0.0, a), b)
                         for n, a, b in zip(self.names, self.lower, self.upper, strict=True)])


# --------------------------------------------------------------------------------------
# the toolpath


class Toolpath:
    """Nozzle path p(s) + D(s) (PCHIP offsets, module docstring) traversed at constant
    ``speed`` [m/s].  ``position(t)``, ``velocity(t)``, ``duration``: the path protocol."""

    #: intervals of the arc-length table per metre of path (at least 2000 in all)
    SAMPLES_PER_M = 2e5

    def __init__(self, desired: DesiredPath, speed: float, s=(), delta=()):
        if not speed > 0:
            raise ValueError(f"nozzle speed must be positive, got {speed}")
        self.desired = desired
        self.speed = float(speed)
        s = np.asarray(s, dtype=float).ravel()
        delta = np.asarray(delta, dtype=float).ravel()
        if s.shape != delta.shape:
            raise ValueError("s and delta need one value per waypoint")
        if np.any((s < 0) | (s > 1)):
            raise ValueError("waypoint s must lie in [0, 1]")
        # fixed end waypoints (s = 0 and 1, delta = 0) unless given; sort; drop repeated s
        keep_end = [e for e in (0.0, 1.0) if not np.any(np.isclose(s, e, atol=1e-12))]
        s = np.concatenate([s, keep_end])
        delta = np.concatenate([delta, np.zeros(len(keep_end))])
        order = np.argsort(s, kind="stable")
        s, delta = s[order], delta[order]
        uniq = np.concatenate([[True], np.diff(s) > 1e-9])
        self.s, self.delta = s[uniq], delta[uniq]
        #: the offset waypoints w~_i (eq. 3.44)
        self.waypoints = desired.point(self.s) + self.delta[:, None] * desired.normal(self.s)
        self._offset = PchipInterpolator(
            self.s, self.delta[:, None] * desired.normal(self.s), axis=0)
        self._doffset = self._offset.derivative()
        # arc-length table of the nozzle path (corners of the desired path included)
        n = max(2000, int(self.SAMPLES_PER_M * desired.length))
        grid = np.unique(np.concatenate([np.linspace(0, 1, n), desired.breaks, self.s]))
        # arc length = integral of |dp_nozzle/ds| by 4-point Gauss-Legendre per interval
        # (exact pieces between the grid points: the joints and waypoints are grid points)
        xg, wg = np.polynomial.legendre.leggauss(4)
        a, b = grid[:-1], grid[1:]
        sq = 0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * xg
        seg = 0.5 * (b - a) * (self._ds_norm(sq) @ wg)
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        self._grid, self._arc = grid, arc
        # s(arc) as a cubic Hermite spline with ds/darc = 1 / |dp_nozzle/ds| at the nodes
        self._s_of_arc = CubicHermiteSpline(arc, grid, 1.0 / self._ds_norm(grid))
        self.length = float(arc[-1])
        self.duration = self.length / self.speed

    @classmethod
    def naive(cls, desired: DesiredPath, speed: float) -> Toolpath:
        """The nozzle follows the desired path itself."""
        return cls(desired, speed)

    @classmethod
    def from_parameters(cls, desired: DesiredPath, space: ParameterSpace, x,
                        speed: float) -> Toolpath:
        """The toolpath of parameter vector ``x`` of ``space`` (eq. 3.46)."""
        s, d = space.waypoints(x)
        return cls(desired, speed, s, d)

    def point(self, s):
        """Nozzle path at parameter s of the desired path: p(s) + D(s) [m]."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
        return self.desired.point(s) + self._offset(s)

    def _derivative(self, s):
        """dp_nozzle/ds [m]: the one-sided (right) tangent of the desired path at a joint."""
        s, k, u = self.desired._locate(s)
        tan = np.empty(s.shape + (2,))
        for i, piece in enumerate(self.desired.pieces):
            m = k == i
            if np.any(m):
                tan[m] = piece.tangent(u[m])
        return tan * self.desired.length + self._doffset(s)

    def _ds_norm(self, s):
        return np.linalg.norm(self._derivative(s), axis=-1)

    def _s_of_t(self, t):
        arc = np.clip(np.asarray(t, dtype=float) * self.speed, 0.0, self.length)
        return np.clip(self._s_of_arc(arc), 0.0, 1.0)

    def position(self, t):
        """Nozzle xy [m] at time t [s] (t clipped to [0, duration]); (2,) for scalar t."""
        return self.point(self._s_of_t(t))

    def velocity(self, t):
        """Nozzle velocity [m/s] at time t: ``speed`` along the path's tangent (the
        one-sided tangent after a corner); zero outside (0, duration)."""
        t = np.asarray(t, dtype=float)
        d = self._derivative(self._s_of_t(t))
        norm = np.linalg.norm(d, axis=-1, keepdims=True)
        v = self.speed * d / np.where(norm > 0, norm, 1.0)
        moving = (t > 0) & (t < self.duration)
        return np.where(moving[..., None], v, 0.0)


# --------------------------------------------------------------------------------------
# named cases (thesis section 3.4)

#: nozzle diameter of the thesis (table 3.2) [m]
THESIS_NOZZLE_DIAMETER = 0.7e-3


def _bend180(leg: float, radius: float, name: str) -> DesiredPath:
    return DesiredPath([Line((-leg, 0.0), (0.0, 0.0)),
                        Arc((0.0, radius), radius, -math.pi / 2, math.pi),
                        Line((0.0, 2 * radius), (-leg, 2 * radius))], name=name)


def _bend90(leg: float) -> DesiredPath:
    return DesiredPath([Line((-leg, 0.0), (0.0, 0.0)), Line((0.0, 0.0), (0.0, leg))],
                       name="bend90")


def _case_bend90(leg=5e-3, radius=None):
    """Table 3.3: three free waypoints after the corner, s in (0.5, 0.9) [the corner is at
    s = 0.5 here], |delta| <= 1.5 mm; one at the corner with |delta| <= 0.5 mm; the thesis
    bounds are one-sided (0, d) for its orientation, ours are symmetric."""
    path = _bend90(leg)
    specs = [WaypointSpec((0.5, 0.9), (-1.5e-3, 1.5e-3)) for _ in range(3)]
    specs.append(WaypointSpec(0.5, (-0.5e-3, 0.5e-3)))
    return path, specs


#: bend90-corner: waypoints after the corner, as fractions of the leg from it
CORNER_WAYPOINTS = (0.16, 0.32, 0.48)
#: ... where the nozzle leaves the desired path before the corner and where it is back on
#: it after the corner (fixed waypoints, delta = 0), as fractions of the leg from the corner
CORNER_LEAVE, CORNER_RETURN = 0.32, 0.72


def _case_bend90_corner(leg=5e-3, radius=None):
    """The 90-degree bend with 4 free offsets only, all near the corner, at fixed s: the
    corner (bisector, delta in (-0.5, 0) mm) and 3 waypoints 0.16, 0.32, 0.48 leg after it
    (delta in (-1, 0) mm), between two fixed waypoints on the path (delta = 0) at 0.32 leg
    before and 0.72 leg after the corner, so the offsets stay local: the rest of both legs
    is the desired path.  The offsets point inwards only, as
    the thesis' one-sided bounds (table 3.3): the ink that lags behind the nozzle carries
    the first leg's direction past the corner (outwards; docs/diw.md).  The offsets' range
    is about twice the naive overshoot at D = 0.7 mm (0.4 mm), narrower than table 3.3's
    1.5 mm so that a budget of tens of evaluations samples it usefully."""
    path = _bend90(leg)
    specs = [WaypointSpec(0.5 - 0.5 * CORNER_LEAVE, 0.0), WaypointSpec(0.5, (-0.5e-3, 0.0))]
    specs += [WaypointSpec(0.5 + 0.5 * f, (-1.0e-3, 0.0)) for f in CORNER_WAYPOINTS]
    specs.append(WaypointSpec(0.5 + 0.5 * CORNER_RETURN, 0.0))
    return path, specs


def _case_bend180(leg, radius, name, n_free):
    path = _bend180(leg, radius, name)
    a, b = path.breaks[1], path.breaks[2]  # s at the start and the end of the half circle
    if n_free == 4:  # table 3.4
        specs = [WaypointSpec((0.1, a), 0.0), WaypointSpec((a, b), (-2e-3, 2e-3)),
                 WaypointSpec((a, b), (-2e-3, 2e-3)), WaypointSpec((b, 0.9), 0.0)]
    else:  # table 3.5: five along the half circle, delta in (-2 mm, 0) (inwards)
        specs = [WaypointSpec((a, b), (-2e-3, 0.0)) for _ in range(n_free)]
    return path, specs


def _case_small(leg=5e-3, radius=2e-3):
    return _case_bend180(leg, radius, "bend180-small", 4)


def _case_large(leg=5e-3, radius=5e-3):
    return _case_bend180(leg, radius, "bend180-large", 5)


def _case_line(leg=5e-3, radius=None):
    path = DesiredPath([Line((0.0, 0.0), (leg, 0.0))], name="line")
    return path, [WaypointSpec((0.2, 0.8), (-1e-3, 1e-3))]


CASES = {"bend90": _case_bend90, "bend90-corner": _case_bend90_corner,
         "bend180-small": _case_small,
         "bend180-large": _case_large, "line": _case_line}


def named_case(name: str, leg: float | None = None,
               radius: float | None = None) -> tuple[DesiredPath, ParameterSpace]:
    """The desired path and the waypoint parameter space of a named case.

    ``leg``: length of the straight legs [m] (default 5 mm); ``radius``: of the half circle
    of the 180-degree bends [m] (default 2 mm small, 5 mm large).  With the defaults, the
    large bend's half circle spans s = 0.19-0.81, near the thesis' bounds (0.2, 0.8).
    """
    if name not in CASES:
        raise ValueError(f"unknown toolpath case {name!r} (known: {', '.join(CASES)})")
    kw = {k: v for k, v in (("leg", leg), ("radius", radius)) if v is not None}
    path, specs = CASES[name](**kw)
    return path, ParameterSpace(specs)
