"""The ``[fluid.packing]`` scene sub-section (pure declarations, no numba import): the
initial particle packing of :mod:`sphfem.fluid.packing`, run once before the first step."""

from __future__ import annotations

from sphfem.schema import Param, Section

PACKING = Section("packing", (
    Param("iterations", int, 0, ge=0,
          doc="largest number of packing iterations before the first step (0: off, the "
              "fluid starts on its block lattice; ~1000-3000 reach the tolerance)"),
    Param("tolerance", float, 1e-5, positive=True,
          doc="stop when the packing force max |grad Gamma| R, Gamma = sum_j V_j W_ij, is "
              "at most this"),
    Param("jitter", float, 0.1, gt=0.0, le=0.5,
          doc="start displacement: a seeded uniform random vector of at most this many dx "
              "per axis (the lattice is a saddle of the packing energy)"),
    Param("seed", int, 0, ge=0, doc="seed of the start displacement"),
), doc=(
    "Initial particle packing (Colagrossi et al. 2012, Comput. Phys. Commun. 183): the "
    "fluid particles are moved, once before the first step, to a minimum of the kernel "
    "energy sum_ij V_i V_j W_ij against the fixed wall particles (the free boundaries are "
    "closed by the empty sites of the fluid lattice, removed afterwards), so that the "
    "uniform-pressure SPH force vanishes on every particle.  A Cartesian lattice is not a "
    "stable arrangement under a pressure gradient: a column at rest started on it "
    "resettles by column-wise slip (see `sphfem validate hydrostatic`).  The outcome "
    "(iterations, residual, largest shift) is in summary.json under the fluid's "
    "diagnostics.  Not applied on --resume."))
