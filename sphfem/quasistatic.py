"""The quasi-static substrate's ``solve``, shared by the FEM and the TL-SPH substrates.

A quasi-static substrate answers each coupling step's loads with the equilibrium state
``K u = f(dT, t, F, b)`` (FEM: one back-substitution with the factorised stiffness;
TL-SPH: dynamic relaxation to the same state).  The loads are stated in one vocabulary
(:mod:`sphfem.loads`): a temperature change ``dT_nodal`` or absolute ``T_nodal``
(dT = T - T0), ``tractions`` by boundary name, ``point_forces`` snapped onto the face
``snap``, a ``body_force`` and, where the substrate has one, a ready nodal ``load`` vector.

:class:`QuasiStaticSubstrate` holds the one :meth:`~QuasiStaticSubstrate.solve`; a
substrate states its three steps:

``_assemble(dT, tractions, point_forces, body_force, snap, load) -> loads``
    this step's loads in the substrate's own form (FEM: the nodal vector f);
``_respond(loads, info) -> state``
    the equilibrium state under them; may add figures to ``info`` (CG iterations,
    relaxation steps);
``_result(state, loads, dT, info) -> result``
    the substrate's result object (displacement, stress, ``probe``).

``info`` holds ``assemble_load_s`` and ``solve_s`` [s] (load assembly, then the response
and the result) for every substrate; ``n_solves`` counts the solves.
"""

from __future__ import annotations

import time

from sphfem.loads import temperature_change


class QuasiStaticSubstrate:
    """Base of the quasi-static substrates (see the module docstring); a subclass sets
    ``T0`` [K] and ``n_solves`` and implements ``_assemble``, ``_respond`` and ``_result``."""

    T0: float
    n_solves: int

    def solve(self, dT_nodal=None, tractions=None, point_forces=None, body_force=None,
              T_nodal=None, snap: str | None = "top", load=None):
        """Equilibrium under this step's loads.

        dT_nodal : temperature change: scalar, callable of the coordinates (dim, n) or one
            value per node / particle.
        T_nodal : absolute temperature instead (dT = T - T0).
        tractions : ``{boundary: t}``, t constant (dim,) or callable of x [Pa].
        point_forces : ``(points, forces)``, each (n, dim) [m, N]; points are snapped onto
            the boundary ``snap`` (None: used as given, FEM; nearest body particle, TL-SPH).
        body_force : constant (dim,) or callable of x [N/m^dim].
        load : a ready nodal load vector (e.g. a coupling transfer's P^T F), added as is.
        """
        t0 = time.perf_counter()
        dT = temperature_change(dT_nodal, T_nodal, self.T0)
        loads = self._assemble(dT, tractions, point_forces, body_force, snap, load)
        t1 = time.perf_counter()
        info = {"assemble_load_s": t1 - t0}
        state = self._respond(loads, info)
        result = self._result(state, loads, dT, info)
        info["solve_s"] = time.perf_counter() - t1
        self.n_solves += 1
        return result

    def _assemble(self, dT, tractions, point_forces, body_force, snap, load):
        raise NotImplementedError

    def _respond(self, loads, info):
        raise NotImplementedError

    def _result(self, state, loads, dT, info):
        raise NotImplementedError
