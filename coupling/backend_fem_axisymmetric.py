"""The axisymmetric FEM substrate as a coupling backend ("fem-axisymmetric").

Wraps a :class:`sphfem.fem.axisymmetric.AxisymmetricFEMSubstrate` with the protocol of
:mod:`coupling.backends` (``apply``, ``solve``, ``write``, ``diagnostics``).  Everything
lives in the (r, z) half-plane: sensor points, forces and temperature points are (n, 2)
arrays of (r, z).

Forces.  ``force_convention="ring"`` (default): each sensor force is the total force of
its ring [N] (an axisymmetric SPH particle stands for a ring of radius r, ring mass times
acceleration); ``"radian"``: the force per radian [N/rad]; ``"line"``: the line density
f [N/m] along the ring (planar mass times acceleration), ring total 2 pi r f.  The forces
are turned into ring totals, handed over by the conservative f = P^T F of
:class:`coupling.transfer.ForceTransfer` and divided by 2 pi (the substrate's equations are
per radian).  The bookkeeping (``force_in`` / ``force_out``, moments) is in ring totals
[N], so its z component is the net axial force on the substrate.

Temperatures go through :class:`coupling.transfer.TemperatureMap` in the half-plane;
``vol`` must then be the particles' (r, z) cell areas [m^2] (the map's cells tile the
plane), not their ring volumes.

``CoupledResult.cell_volume`` holds the ring volumes 2 pi int r dr dz of the cells, so
``mean_stress`` is the volume average over the body of revolution; stress tensors are in
the (r, z, theta) order of the substrate (index 2 is the hoop direction).

Registration.  Importing this module adds ``"fem-axisymmetric"`` to
:data:`coupling.backends.BACKENDS` (so :func:`coupling.backends.make_backend` builds it).
``coupling.backends`` cannot import this module itself: the class subclasses its
:class:`~coupling.backends.FEMBackend`, and the import would be a cycle; the code that
selects the backend (the driver) imports this module.
"""

from __future__ import annotations

import numpy as np

from coupling.backends import BACKENDS, FEMBackend

__all__ = ["AxisymmetricFEMBackend"]


class AxisymmetricFEMBackend(FEMBackend):
    """Backend of an axisymmetric FEM substrate; see the module docstring for units."""

    name = "fem-axisymmetric"

    def __init__(self, substrate, surface: str = "top", temperature_map: str = "mls",
                 R: float | None = None, kernel: str = "wendland_c2",
                 force_convention: str = "ring"):
        from sphfem.fem.axisymmetric import FORCE_CONVENTIONS, AxisymmetricFEMSubstrate

        if not isinstance(substrate, AxisymmetricFEMSubstrate):
            raise TypeError(f"fem-axisymmetric backend: need an AxisymmetricFEMSubstrate, got "
                            f"{type(substrate).__name__}")
        if force_convention not in FORCE_CONVENTIONS:
            raise ValueError(f"force_convention must be one of {FORCE_CONVENTIONS}, got "
                             f"{force_convention!r}")
        super().__init__(substrate, surface, temperature_map, R, kernel)
        self.force_convention = force_convention
        self._cell_volume = substrate.cell_volume  # ring volumes, not (r, z) areas

    def apply(self, points, forces, T_points=None, T=None, vol=None) -> dict:
        from sphfem.fem.axisymmetric import per_radian

        pts = np.atleast_2d(np.asarray(points, float)).reshape(-1, 2)
        ring = 2.0 * np.pi * per_radian(pts, np.reshape(forces, (-1, 2)),
                                        self.force_convention)
        book = super().apply(pts, ring, T_points, T, vol)
        self._f = self._f / (2.0 * np.pi)  # ring totals -> per radian
        return book

    def diagnostics(self) -> dict:
        d = super().diagnostics()
        d.update(backend=self.name, force_convention=self.force_convention)
        return d


BACKENDS["fem-axisymmetric"] = AxisymmetricFEMBackend
