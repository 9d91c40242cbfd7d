"""Particle storage as a structure of arrays, and the simulation domain.

All per-particle state lives in one :class:`ParticleSet` (``dict`` of C-contiguous arrays),
so that a single :meth:`ParticleSet.reorder` applies a cell sort to every field.  Physics
modules declare the fields they need and never keep private per-particle arrays.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np
from numba import njit


class ParticleKind(IntEnum):
    """Particle kinds, the values of the int8 field ``kind`` (compare by name:
    ``ps.kind != ParticleKind.GHOST``, never ``ps.kind != 3``)."""

    FLUID = 0
    WALL = 1  # boundary particles of a solid seen by a fluid (also the substrate's SPH particles)
    SOLID = 2  # particles of an SPH solid body (heat or TL-SPH)
    GHOST = 3  # boundary-condition ghosts (heat)


# the same values as plain ints, for numba kernels (compile-time constants)
FLUID = int(ParticleKind.FLUID)
WALL = int(ParticleKind.WALL)
SOLID = int(ParticleKind.SOLID)
GHOST = int(ParticleKind.GHOST)

#: scene name of a kind -> its value ("fluid" -> 0, ...)
KIND_NAMES = {k.name.lower(): int(k) for k in ParticleKind}

CORE_FIELDS = ("x", "m", "rho", "vol", "kind", "material", "id")


@dataclass
class Domain:
    """Axis-aligned box ``[lo, hi]`` with optionally periodic axes."""

    lo: np.ndarray
    hi: np.ndarray
    periodic: tuple[bool, ...] = ()

    def __post_init__(self):
        self.lo = np.asarray(self.lo, dtype=np.float64)
        self.hi = np.asarray(self.hi, dtype=np.float64)
        if self.lo.shape != self.hi.shape or self.lo.ndim != 1:
            raise ValueError("domain lo and hi must be vectors of the same length")
        if not self.periodic:
            self.periodic = (False,) * self.dim
        self.periodic = tuple(bool(p) for p in self.periodic)
        if len(self.periodic) != self.dim:
            raise ValueError("domain periodic flags must have one entry per axis")
        if np.any(self.hi <= self.lo):
            raise ValueError("domain hi must exceed lo on every axis")

    @property
    def dim(self) -> int:
        return self.lo.shape[0]

    @property
    def period(self) -> np.ndarray:
        """Length of each periodic axis, 0 for non-periodic axes (the numba convention)."""
        return np.where(self.periodic, self.hi - self.lo, 0.0)

    @classmethod
    def around(cls, x: np.ndarray, margin: float) -> Domain:
        """The bounding box of positions ``x`` (n, dim) enlarged by ``margin``."""
        return cls(x.min(axis=0) - margin, x.max(axis=0) + margin)


@dataclass
class ParticleSet:
    """Structure-of-arrays particle container.

    Core fields: ``x`` (n, dim) positions [m], ``m`` mass [kg], ``rho`` density [kg/m^3],
    ``vol`` volume m/rho [m^3], ``kind`` (int8, :class:`ParticleKind`), ``material`` (int32
    index into the scene's materials), ``id`` (int64, stable across reorders).
    Further fields are added by physics modules through :meth:`add_field`.
    """

    dim: int
    fields: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def from_arrays(cls, x, m=None, rho=None, vol=None, kind=None, material=None) -> ParticleSet:
        """Build a set from positions and optional per-particle arrays (scalars broadcast)."""
        x = np.ascontiguousarray(np.atleast_2d(np.asarray(x, dtype=np.float64)))
        n, dim = x.shape
        ps = cls(dim=dim)
        ps.fields["x"] = x
        rho_a = np.full(n, 1.0) if rho is None else np.broadcast_to(np.asarray(rho, float), (n,))
        if vol is None and m is None:
            raise ValueError("give the particle volume or the particle mass")
        if vol is None:
            vol = np.broadcast_to(np.asarray(m, float), (n,)) / rho_a
        vol_a = np.broadcast_to(np.asarray(vol, float), (n,))
        m_a = rho_a * vol_a if m is None else np.broadcast_to(np.asarray(m, float), (n,))
        ps.fields["rho"] = np.array(rho_a, dtype=np.float64)
        ps.fields["vol"] = np.array(vol_a, dtype=np.float64)
        ps.fields["m"] = np.array(m_a, dtype=np.float64)
        kind = FLUID if kind is None else kind
        ps.fields["kind"] = np.array(np.broadcast_to(kind, (n,)), np.int8)
        ps.fields["material"] = np.array(
            np.broadcast_to(0 if material is None else material, (n,)), np.int32
        )
        ps.fields["id"] = np.arange(n, dtype=np.int64)
        return ps

    @property
    def n(self) -> int:
        return self.fields["x"].shape[0]

    def __getattr__(self, name):
        try:
            return self.__dict__["fields"][name]
        except KeyError:
            raise AttributeError(name) from None

    def __contains__(self, name: str) -> bool:
        return name in self.fields

    def add_field(self, name: str, ncomp: int = 1, dtype=np.float64, fill=0.0) -> np.ndarray:
        """Allocate (or return the existing) per-particle field ``name``."""
        if name in self.fields:
            return self.fields[name]
        shape = (self.n,) if ncomp == 1 else (self.n, ncomp)
        arr = np.full(shape, fill, dtype=dtype)
        self.fields[name] = arr
        return arr

    def reorder(self, perm: np.ndarray) -> None:
        """Permute every field by ``perm`` (new index k holds old particle ``perm[k]``)."""
        for k, a in self.fields.items():
            self.fields[k] = np.ascontiguousarray(a[perm])

    def select(self, mask: np.ndarray) -> ParticleSet:
        """A new set holding copies of the particles where ``mask`` is true."""
        fields = {k: np.ascontiguousarray(a[mask]) for k, a in self.fields.items()}
        return ParticleSet(self.dim, fields)

    def append(self, other: ParticleSet) -> None:
        """Concatenate ``other`` (same dim); fields missing on one side are zero-filled."""
        if other.dim != self.dim:
            raise ValueError("cannot append particle sets of different dimension")
        if self.n == 0:
            self.fields = {k: a.copy() for k, a in other.fields.items()}
            return
        start = int(self.fields["id"].max()) + 1 if self.n else 0
        for k in set(self.fields) | set(other.fields):
            a = self.fields.get(k)
            b = other.fields.get(k)
            if a is None:
                a = np.zeros((self.n,) + b.shape[1:], b.dtype)
            if b is None:
                b = np.zeros((other.n,) + a.shape[1:], a.dtype)
            if k == "id":
                b = b + start
            self.fields[k] = np.ascontiguousarray(np.concatenate([a, b]))

    def check_finite(self, names=None) -> list[str]:
        """Names of float fields holding NaN or Inf (empty when all are finite)."""
        bad = []
        for k in names or self.fields:
            a = self.fields[k]
            if a.dtype.kind == "f" and not _all_finite(a.reshape(-1)):
                bad.append(k)
        return bad


@njit(cache=True)
def _all_finite(a):
    for i in range(a.shape[0]):
        if not np.isfinite(a[i]):
            return False
    return True
