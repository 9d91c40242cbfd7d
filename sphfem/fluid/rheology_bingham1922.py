"""Bingham plastic (``rheology = "bingham"``).

E. C. Bingham (1922), Fluidity and Plasticity, McGraw-Hill: |tau| = tau0 + k gamma_dot where
the fluid yields, rigid below, with ``k`` the plastic viscosity [Pa s]: the Herschel-Bulkley
law with n = 1, regularised below ``gamma_dot_0`` (:mod:`sphfem.fluid.rheology`).
"""

from __future__ import annotations

from sphfem.fluid.rheology import RheologyMethod, register

METHOD = register(RheologyMethod(
    name="bingham",
    doc="Bingham (1922): yield stress tau0 and plastic viscosity k (n = 1), regularised "
        "below gamma_dot_0",
    params=(),
    coefficients=lambda pa: (pa.tau0, pa.k, 1.0),
))
