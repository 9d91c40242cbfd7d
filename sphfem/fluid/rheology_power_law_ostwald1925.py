"""Power-law (Ostwald-de Waele) fluid (``rheology = "power-law"``).

W. Ostwald (1925), Kolloid-Zeitschrift 36, 99; A. de Waele (1923), J. Oil Colour Chem.
Assoc. 6, 33: mu = k gamma_dot^(n-1), the Herschel-Bulkley law with tau0 = 0; held at
k gamma_dot_0^(n-1) below ``gamma_dot_0`` (bounded for n < 1; :mod:`sphfem.fluid.rheology`).
"""

from __future__ import annotations

from sphfem.fluid.rheology import RheologyMethod, register

METHOD = register(RheologyMethod(
    name="power-law",
    doc="Ostwald-de Waele power law mu = k gamma_dot^(n-1) (tau0 = 0), held at gamma_dot_0 "
        "below it",
    params=(),
    coefficients=lambda pa: (0.0, pa.k, pa.n),
))
