"""Herschel-Bulkley fluid (``rheology = "herschel-bulkley"``).

W. H. Herschel, R. Bulkley (1926), Kolloid-Zeitschrift 39, 291: |tau| = tau0 + k gamma_dot^n
where the fluid yields (|tau| > tau0), rigid below; the yield stress ``tau0``, consistency
``k`` and flow index ``n`` are ``[fluid]`` keys, regularised below ``gamma_dot_0`` (see
:mod:`sphfem.fluid.rheology`).  tau0 = 0 is the power law, n = 1 the Bingham fluid.
"""

from __future__ import annotations

from sphfem.fluid.rheology import RheologyMethod, register

METHOD = register(RheologyMethod(
    name="herschel-bulkley",
    doc="Herschel & Bulkley (1926): yield stress tau0, consistency k, index n, regularised "
        "below gamma_dot_0 (cutoff or papanastasiou)",
    params=(),
    coefficients=lambda pa: (pa.tau0, pa.k, pa.n),
))
