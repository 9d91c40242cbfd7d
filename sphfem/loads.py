"""Load specifications shared by the quasi-static substrates (FEM and TL-SPH).

Both :class:`sphfem.fem.FEMSubstrate` and :class:`sphfem.solid.backend.TLSPHSubstrate` take
the loads of a step in one vocabulary:

* a temperature change ``dT_nodal`` -- or the absolute ``T_nodal``, dT = T - T0
  (:func:`temperature_change`) -- given as a scalar, a callable of the coordinates or one
  value per node / particle;
* tractions and body forces given as a constant vector or a callable of the coordinates.

A callable receives the coordinates as scikit-fem does, ``x`` of shape (dim, n), and returns
(n,) values for a scalar or (dim, n) for a vector (a constant result is broadcast).
:func:`at_points` evaluates the constant / callable forms; :func:`scalar_at` a temperature
change in any of its forms, handing arrays of per-node values to the substrate (they need its
node set or its interpolation).
"""

from __future__ import annotations

import numpy as np


def temperature_change(dT_nodal, T_nodal, T0: float):
    """The temperature change of a solve: ``dT_nodal`` as given, or ``T_nodal - T0`` in the
    same form (scalar, array or callable).  Giving both is an error."""
    if T_nodal is None:
        return dT_nodal
    if dT_nodal is not None:
        raise ValueError("give dT_nodal or T_nodal, not both")
    if callable(T_nodal):
        return lambda x: np.asarray(T_nodal(x)) - T0
    return np.asarray(T_nodal, float) - T0


def at_points(spec, X: np.ndarray, ncomp: int | None = None) -> np.ndarray:
    """Values of a constant or callable load ``spec`` at the points ``X`` (dim, n).

    ``ncomp`` None: a scalar field, returns (n,); otherwise a vector field of ``ncomp``
    components, returns (n, ncomp).  ``spec`` None means zero.  The result may be a
    read-only broadcast view; copy it before writing into it.
    """
    n = X.shape[1]
    shape = (n,) if ncomp is None else (n, ncomp)
    if spec is None:
        return np.zeros(shape)
    if callable(spec):
        v = np.asarray(spec(X), float)
        return np.broadcast_to(v if ncomp is None else v.T, shape)
    return np.broadcast_to(np.asarray(spec, float), shape)


def scalar_at(spec, X: np.ndarray, nodal) -> np.ndarray:
    """A scalar field (a temperature change) at the points ``X`` (dim, n), as a new array:
    None (zero), a constant or a callable of the coordinates through :func:`at_points`; an
    array of per-node values through the substrate's ``nodal(values) -> (n,)``."""
    if spec is None or callable(spec) or np.ndim(spec) == 0:
        return at_points(spec, X).copy()
    return nodal(np.asarray(spec, float))
