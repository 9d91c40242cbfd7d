"""Laminar viscosity in the form of Shao & Lo (2003) (``viscosity = "laminar"``).

    <mu/rho lap u>_i = sum_j 4 m_j (mu_i + mu_j) (r_ij . grad_i W_ij)
                             / ((rho_i + rho_j)^2 (r_ij^2 + eps h^2)) u_ij

(Shao & Lo 2003, Adv. Water Resour. 26, 787; Park 2019 eq. 2.21 / 2.86, citing them; a
variant of the Morris et al. 1997 term with the mean density squared in place of rho_i
rho_j).  ``eps`` is ``[fluid] eps_visc``.  A wall neighbour takes the fluid particle's mu
and the wall model's ghost velocity.  The term is fused into the WCSPH force pass
(:func:`sphfem.fluid.passes.fluid_forces`), so this module only registers it.
"""

from __future__ import annotations

from sphfem.fluid.viscosity import ViscosityMethod, register

METHOD = register(ViscosityMethod(
    name="laminar",
    doc="Newtonian, in the form of Shao & Lo (2003) (thesis eq. 2.21: 4 m_j (mu_i + mu_j) / "
        "(rho_i + rho_j)^2, a variant of Morris et al. 1997) with each fluid particle's "
        "material mu",
    params=(),
    fused=True,
))
