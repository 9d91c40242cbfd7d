"""Parameters of the heat-conduction module: :class:`HeatParams`, built from a scene's
``[heat]`` section (:mod:`sphfem.heat.scene_section`, docs/scenes.md) and its materials by
:func:`params_from_scene`, or passed directly to ``HeatConduction(scene, params)``.

Keys and units (the same names as the ``[heat]`` keys):

``laplacian``          "cleary" (Cleary 1998, harmonic-mean k, conservative) or
                       "fatehi_manzari" (corrected, exact for quadratics; per-particle
                       fallback to the plain form where singular).
``time_integration``   "explicit" (Heun, dt from the thermal limit) or "implicit"
                       (theta method, sparse LU factorised once; every step when
                       another module moves the particles).
``theta``              implicit weight: 1 backward Euler, 0.5 Crank-Nicolson.
``implicit_dt_factor`` implicit step as a multiple of the explicit stable step [-].
``dt``                 fixed heat step [s] (overrides ``implicit_dt_factor``).
``cfl``                safety factor on the explicit limit (<= 1) [-].
``startup``            Crank-Nicolson steps replaced by two backward-Euler half steps.
``bound_margin``       guard: stop when T leaves the initial/wall range widened by this
                       fraction of its width (maximum principle) [-].
``positivity_limiter`` corrected form: blend rows with a negative weight towards the plain
                       row until every weight is >= 0.
``free_surface_plain`` corrected form only: particles with number density below this (and
                       all within R of a free face) use the plain rows (zero-flux free
                       surface; the corrected operator has growing modes there otherwise).
``eta_place``          ghosts are placed around particles with number density below this.
``eta_trim``           ghosts with number density above this are removed.
``dirichlet_ghosts``   "antisymmetric" (T_g = 2 T_w - T_mirror, second order, default)
                       or "hold" (T_g = T_w, the thesis' rule; first order, see heat1d).
``insulated_source``   "mirror" (copy the real particle at the mirror image, default) or
                       "nearest" (copy the nearest real particle, the thesis' wording).
``boundaries``         list of :class:`BoxBoundary`: a box [lo, hi] [m] and its faces
                       "xmin" ... "zmax" -> "insulated" | "free" | ("dirichlet", T [K]).
``materials``          material id -> :class:`ThermalMaterial` (c [J/(kg K)], k [W/(m K)]).
``initial_temperature`` [K] for particles whose T is not set beforehand (None: keep).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sphfem.heat.conduction import LAPLACIANS

TIME_INTEGRATIONS = ("explicit", "implicit")


@dataclass
class ThermalMaterial:
    """Specific heat capacity ``c`` [J/(kg K)] and conductivity ``k`` [W/(m K)]."""

    c: float
    k: float


@dataclass
class BoxBoundary:
    """Faces of the box [lo, hi] with their conditions (unnamed faces: insulated)."""

    lo: tuple
    hi: tuple
    faces: dict = field(default_factory=dict)


@dataclass
class HeatParams:
    laplacian: str = "cleary"
    time_integration: str = "explicit"
    theta: float = 1.0
    implicit_dt_factor: float | None = None
    dt: float | None = None
    cfl: float = 1.0
    startup: int = 1
    bound_margin: float = 0.1
    positivity_limiter: bool = True
    free_surface_plain: float = 0.85
    eta_place: float = 0.85
    eta_trim: float = 1.3
    dirichlet_ghosts: str = "antisymmetric"
    insulated_source: str = "mirror"
    boundaries: list[BoxBoundary] = field(default_factory=list)
    materials: dict[int, ThermalMaterial] = field(default_factory=dict)
    initial_temperature: float | None = None

    def __post_init__(self):
        if self.laplacian not in LAPLACIANS:
            raise ValueError(f"heat.laplacian must be one of {LAPLACIANS}, got "
                             f"{self.laplacian!r}")
        if self.time_integration not in TIME_INTEGRATIONS:
            raise ValueError(f"heat.time_integration must be one of {TIME_INTEGRATIONS}")
        if not 0.5 <= self.theta <= 1.0:
            raise ValueError(f"heat.theta must lie in [0.5, 1], got {self.theta}")
        if not 0.0 < self.cfl <= 1.0:
            raise ValueError(f"heat.cfl must lie in (0, 1], got {self.cfl}")
        if self.dirichlet_ghosts not in ("hold", "antisymmetric"):
            raise ValueError("heat.dirichlet_ghosts must be 'hold' or 'antisymmetric'")
        if self.insulated_source not in ("mirror", "nearest"):
            raise ValueError("heat.insulated_source must be 'mirror' or 'nearest'")
        if not self.bound_margin >= 0.0:
            raise ValueError(f"heat.bound_margin must be >= 0, got {self.bound_margin}")
        if not 0.0 < self.eta_place < self.eta_trim:
            raise ValueError("heat: need 0 < eta_place < eta_trim")


def params_from_scene(scene) -> HeatParams:
    """:class:`HeatParams` from a validated scene's ``[heat]`` section and its box blocks."""
    h = scene.heat
    keys = ("laplacian", "time_integration", "theta", "implicit_dt_factor", "dt", "cfl",
            "startup", "bound_margin", "positivity_limiter", "free_surface_plain", "eta_place",
            "eta_trim", "dirichlet_ghosts", "insulated_source")
    kw = {k: h[k] for k in keys} if h is not None else {}
    boundaries = {}
    for b in (h.boundaries if h is not None else ()):
        blk = scene.blocks[scene.block_index(b.block)]
        if blk.shape != "box":
            raise ValueError(f"heat.boundaries: block {b.block!r} is a {blk.shape}; "
                             "faces are defined for box blocks only")
        faces = boundaries.setdefault(b.block, BoxBoundary(tuple(blk.lo), tuple(blk.hi), {}))
        faces.faces[b.face] = ((b.condition, b.temperature) if b.condition == "dirichlet"
                               else b.condition)
    mats = {}
    for i, m in enumerate(scene.materials.values()):
        if m.c is None or m.k is None:
            continue
        mats[i] = ThermalMaterial(m.c, m.k)
    return HeatParams(**kw, boundaries=list(boundaries.values()), materials=mats)
