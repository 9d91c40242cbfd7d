"""The ``[heat]`` scene section (declared once: validation, defaults and docs/scenes.md).

Pure declarations: importing this module compiles nothing.
"""

from __future__ import annotations

from sphfem.schema import REQUIRED, TEMPERATURE, Param, Section

FACES = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")

BOUNDARY = Section("boundaries", (
    Param("block", str, REQUIRED, doc="name of a box `[[blocks]]` entry"),
    Param("face", str, REQUIRED, choices=FACES, doc="face of the block's box"),
    Param("condition", str, REQUIRED, choices=("dirichlet", "insulated", "free"),
          doc="dirichlet: ghosts hold / mirror `temperature`; insulated: ghosts copy the "
              "real particle at their mirror image; free: no ghosts (zero flux with the "
              "Cleary form)"),
    Param("temperature", TEMPERATURE, None, unit="K", doc="wall temperature (dirichlet)"),
), repeated=True, doc="Thermal condition of one face of a box block (`[[heat.boundaries]]`); "
   "faces not listed are insulated where ghosts are placed.")


def _check(rec, ctx, path):
    for i, b in enumerate(rec.boundaries):
        if b.condition == "dirichlet" and b.temperature is None:
            ctx.error(f"{path}.boundaries[{i}].temperature",
                      "missing: a dirichlet face needs a temperature")
    if rec.time_integration == "explicit" and (rec.implicit_dt_factor is not None):
        ctx.error(f"{path}.implicit_dt_factor",
                  "applies only to time_integration = \"implicit\"")


HEAT = Section("heat", (
    Param("laplacian", str, "cleary", choices=("cleary", "fatehi_manzari"),
          doc="cleary: Cleary (1998) harmonic-mean form, conserves sum m c T; "
              "fatehi_manzari: corrected, exact for quadratics, plain fallback where singular"),
    Param("time_integration", str, "explicit", choices=("explicit", "implicit"),
          doc="explicit Heun at the thermal limit, or the implicit theta method "
              "(sparse LU, factorised once; every step when another module moves the "
              "particles, whose conductances are then refreshed every step)"),
    Param("theta", float, 1.0, bounds=(0.5, 1.0),
          doc="implicit weight: 1 backward Euler, 0.5 Crank-Nicolson"),
    Param("implicit_dt_factor", float, None, positive=True,
          doc="implicit step as a multiple of the explicit stable step"),
    Param("dt", float, None, unit="s", positive=True, quantity="time step",
          doc="fixed heat step (overrides implicit_dt_factor)"),
    Param("cfl", float, 1.0, gt=0.0, le=1.0,
          doc="safety factor on the explicit limit dt = 1/max_i sum_j |g_ij|/(rho c)_i"),
    Param("positivity_limiter", bool, True,
          doc="fatehi_manzari: blend each row holding a negative weight with its plain row "
              "until every weight is >= 0 (keeps explicit steps stable and the maximum "
              "principle on disordered particles; lattice interiors keep the exact weights)"),
    Param("bound_margin", float, 0.1, ge=0.0,
          doc="guard: stop when a temperature leaves [T_min - m dT, T_max + m dT], the range "
              "of the initial and wall temperatures widened by this fraction m of its width "
              "dT (conduction obeys a maximum principle; a violation means instability)"),
    Param("startup", int, 1, ge=0,
          doc="Crank-Nicolson steps taken as two backward-Euler half steps (Rannacher)"),
    Param("free_surface_plain", float, 0.85, gt=0.0, le=1.0,
          doc="fatehi_manzari: particles with number density below this, and all within "
              "R of a free face, use the plain rows (stability at free surfaces)"),
    Param("eta_place", float, 0.85, positive=True,
          doc="ghosts are placed around particles with number density below this"),
    Param("eta_trim", float, 1.3, positive=True,
          doc="ghosts whose number density exceeds this are removed"),
    Param("dirichlet_ghosts", str, "antisymmetric", choices=("antisymmetric", "hold"),
          doc="antisymmetric: T_g = 2 T_w - T_mirror (second order); hold: T_g = T_w "
              "(the thesis, first order)"),
    Param("insulated_source", str, "mirror", choices=("mirror", "nearest"),
          doc="insulated ghosts copy the real particle at their mirror image, or the "
              "nearest real particle (the thesis' wording)"),
), subsections=(BOUNDARY,), check=_check,
   doc="Heat conduction rho c dT/dt = div(k grad T) on all non-ghost particles; materials "
       "need `c` and `k`.  Boundary conditions through ghost particles (Park 2019, "
       "algorithm 2.5).")
