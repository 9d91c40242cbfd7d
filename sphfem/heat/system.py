"""The discrete conduction system on a fixed particle set: ghost rules, rate, matrix.

Particles are of three roles (masks over the full set, ghosts included):

* ``active`` -- real particles whose temperature evolves,
* ghosts     -- ``ghost_index`` with a rule per ghost (:mod:`sphfem.heat.ghosts` codes):
  Dirichlet ``hold`` T_g = T_w, Dirichlet ``antisymmetric`` T_g = 2 T_w - T_s, insulated
  T_g = T_s, where s = ``ghost_source`` (an index into the full set),
* anything else keeps its temperature (held particles).

With the pair conductances g (:mod:`sphfem.heat.conduction`) the active temperatures obey

    dT_a/dt = A T_a + f,   A = S L E,  f = S L b                                  (2)

where L = diag(1/(rho c)) [g_ij (T_j - T_i)] is the full operator
(:func:`sphfem.operators.pair_weights_matrix`), E maps active temperatures to all
particles (identity on active rows, the ghost rule's +-1 on ghost rows), b holds the
constant parts (2 T_w or T_w of Dirichlet ghosts, held temperatures) and S selects the
active rows.  The explicit rate and this matrix are the same operator.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit

from sphfem import operators as op
from sphfem.heat.conduction import (
    LAPLACIANS,
    cleary_refresh,
    gershgorin_rows,
    pair_conductances,
)
from sphfem.heat.ghosts import DIRICHLET, INSULATED


class HeatSystem:
    """Conductances and ghost rules for a particle set (moving particles: :meth:`refresh`).

    ``kernel_args`` is the operators' common tail (x, vol, offsets, indices, R, sigma,
    kind, period) over the full set (ghosts included); ``rho_c`` [J/(m^3 K)] and ``k``
    [W/(m K)] are per particle (ghosts carry their source's values).  Use
    rho_c = m c / V so that m c dT/dt = V sum_j g_ij (T_j - T_i) holds exactly.
    """

    def __init__(self, kernel_args, rho_c, k, active, ghost_index=None, ghost_type=None,
                 ghost_source=None, ghost_t_wall=None, laplacian: str = "cleary",
                 dirichlet_mode: str = "hold", plain_rows=None, ghost_ratio=None,
                 limiter: bool = True):
        self.kernel_args = kernel_args
        x, vol, offsets, indices = kernel_args[:4]
        self.offsets, self.indices = offsets, indices
        self.vol = vol
        self.n = x.shape[0]
        self.rho_c = np.ascontiguousarray(rho_c, dtype=np.float64)
        self.k = np.ascontiguousarray(k, dtype=np.float64)
        self.active = np.asarray(active, dtype=bool)
        self.active_index = np.flatnonzero(self.active)
        self.laplacian = laplacian
        self.dirichlet_mode = dirichlet_mode
        if dirichlet_mode not in ("hold", "antisymmetric"):
            raise ValueError("dirichlet_mode must be 'hold' or 'antisymmetric'")
        e = np.zeros(0, np.int64)
        self.ghost_index = e if ghost_index is None else np.asarray(ghost_index, np.int64)
        self.ghost_type = (np.zeros(0, np.int8) if ghost_type is None
                           else np.asarray(ghost_type, np.int8))
        self.ghost_source = e if ghost_source is None else np.asarray(ghost_source, np.int64)
        self.ghost_t_wall = (np.zeros(0) if ghost_t_wall is None
                             else np.asarray(ghost_t_wall, float))
        self.ghost_ratio = (np.ones(self.ghost_index.size) if ghost_ratio is None
                            else np.asarray(ghost_ratio, float))
        if np.any(~self.active[self.ghost_source]):
            raise ValueError("every ghost source must be an active particle")
        self.plain_rows = (np.zeros(self.n, bool) if plain_rows is None
                           else np.asarray(plain_rows, bool) & self.active)
        self.limiter = limiter
        self.inv_rc = 1.0 / self.rho_c
        self._inactive = np.flatnonzero(~self.active)
        # ghost rules on active temperatures, per particle, for the Gershgorin pass: the
        # column (source) and coefficient of each ghost's row of E (-1: no such entry)
        self._rule_src = np.full(self.n, -1, np.int64)
        self._rule_coef = np.zeros(self.n)
        s_ = self.ghost_type == INSULATED
        self._rule_src[self.ghost_index[s_]] = self.ghost_source[s_]
        self._rule_coef[self.ghost_index[s_]] = 1.0
        if dirichlet_mode == "antisymmetric":
            d_ = self.ghost_type == DIRICHLET
            self._rule_src[self.ghost_index[d_]] = self.ghost_source[d_]
            self._rule_coef[self.ghost_index[d_]] = -self.ghost_ratio[d_]
        if laplacian not in LAPLACIANS:
            raise ValueError(f"unknown laplacian {laplacian!r}; expected one of {LAPLACIANS}")
        self.g = np.empty(indices.shape[0])
        # conductances to non-active neighbours (ghosts, held particles): boundary heat
        self.g_outside = np.empty_like(self.g)
        self._rows = np.zeros(self.n)  # Gershgorin sum per particle (0 where not active)
        self._conductances()
        #: conductance refreshes from moved positions since the build (:meth:`refresh`)
        self.refreshes = 0

    def _conductances(self) -> None:
        """g, g_outside, the corrected form's masks and the explicit limit from
        ``kernel_args`` (the Cleary form in one pass, :func:`cleary_refresh`)."""
        args = self.kernel_args
        offsets, indices = args[2], args[3]
        if self.laplacian == "cleary":
            x, vol = args[0], args[1]
            ref = self.__dict__.get("_ref")
            if ref is None or ref[0].shape != x.shape:
                changed = np.ones(self.n, dtype=np.bool_)
            else:  # only pairs with a moved (or resized) particle are recomputed
                changed = _changed(x, vol, ref[0], ref[1])
            cleary_refresh(self.k, *args, self.inv_rc, self.active, self._rule_src,
                           self._rule_coef, self.g, self.g_outside, self._rows, changed)
            self._ref = (x.copy(), vol.copy())
            if not hasattr(self, "ok"):
                self._set_corrections(np.ones(self.n, bool), np.zeros(self.n))
        else:
            g, ok, beta = pair_conductances(
                self.k, *args, laplacian=self.laplacian, plain_rows=self.plain_rows,
                limiter_rows=self.active if self.limiter else None)
            self.g = np.ascontiguousarray(g)
            self._set_corrections(ok, beta)
            self._rows = gershgorin_rows(self.g, offsets, indices, self.inv_rc, self.active,
                                         self._rule_src, self._rule_coef, self.g_outside)
        smax = float(self._rows.max()) if self.n else 0.0
        self._stable_dt = self._dt_of(smax)
        self._vol_active = np.ascontiguousarray(self.vol[self.active])

    def _set_corrections(self, ok, beta) -> None:
        self.ok, self.beta = ok, beta
        #: rows of the corrected form blended towards the plain one by the positivity limiter
        self.limited = int(np.count_nonzero(beta[self.active] > 0))
        # fallbacks counted over active particles only (ghosts' rows are never used)
        self.fallbacks = int((~ok[self.active]).sum())

    def _dt_of(self, smax: float) -> float:
        if self.active_index.size == 0:
            return np.inf
        return 2.0 / smax if smax > 0 else np.inf

    # -- moving particles ----------------------------------------------------------------
    def refresh(self, kernel_args, rho_c=None) -> None:
        """Recompute the conductances, the boundary conductances and the explicit limit
        from the current positions (and volumes) in ``kernel_args``, on the same neighbour
        list (a Verlet-skin list: pairs beyond R get g = 0 because dW/dr vanishes there).

        For particles that another module moves; the set, the list, the ghost rules and
        the ghosts' places are those of the build.  The Cleary form is one numba pass over
        the pairs (conductance, boundary conductance and Gershgorin row in the same loop);
        the corrected form recomputes its renormalisation and limiter per particle, then
        one more pass for the bound.  The free-surface plain rows of the corrected form
        (``plain_rows``) stay those of the build (a particle set by the driver's next
        neighbour rebuild).  ``rho_c`` (per particle, m c / V with the current V) keeps
        m c dT/dt = V sum_j g_ij (T_j - T_i), hence the Cleary energy balance, exact when
        the volumes change.
        """
        x, vol, offsets, indices = kernel_args[:4]
        if offsets.shape[0] != self.n + 1 or indices.shape[0] != self.g.shape[0]:
            raise ValueError("HeatSystem.refresh: the neighbour list changed; rebuild the "
                             "system instead")
        self.kernel_args = kernel_args
        self.offsets, self.indices, self.vol = offsets, indices, vol
        if rho_c is not None:
            self.rho_c = np.ascontiguousarray(rho_c, dtype=np.float64)
            self.inv_rc = 1.0 / self.rho_c
        self._conductances()
        self.refreshes += 1

    # -- ghosts --------------------------------------------------------------------------
    def apply_ghosts(self, T: np.ndarray) -> None:
        """Write the ghost temperatures into ``T`` (full set) from the active ones."""
        gi, gt, gs, tw = self.ghost_index, self.ghost_type, self.ghost_source, self.ghost_t_wall
        d = gt == DIRICHLET
        if self.dirichlet_mode == "hold":
            T[gi[d]] = tw[d]
        else:
            r = self.ghost_ratio[d]
            T[gi[d]] = (1.0 + r) * tw[d] - r * T[gs[d]]
        s = gt == INSULATED
        T[gi[s]] = T[gs[s]]

    # -- operator ------------------------------------------------------------------------
    def rate(self, T: np.ndarray) -> np.ndarray:
        """dT/dt of every particle (zero where not active); ghosts must be up to date."""
        r = op.apply_pair_weights(T, self.g, self.offsets, self.indices) / self.rho_c
        r[self._inactive] = 0.0
        return r

    def matrix(self, T_held: np.ndarray | None = None):
        """(A, f) of eq. (2) on the active particles (A: CSR, n_active^2).

        ``T_held`` supplies the temperatures of held (neither active nor ghost) particles.
        """
        n, na = self.n, self.active_index.size
        col = np.full(n, -1, np.int64)
        col[self.active_index] = np.arange(na)
        rows, cols, vals = [self.active_index], [np.arange(na)], [np.ones(na)]
        b = np.zeros(n)
        held = self.active.copy()
        held[self.ghost_index] = True
        held = ~held
        if T_held is not None:
            b[held] = T_held[held]
        gi, gt, gs, tw = self.ghost_index, self.ghost_type, self.ghost_source, self.ghost_t_wall
        d = gt == DIRICHLET
        s = gt == INSULATED
        if self.dirichlet_mode == "hold":
            b[gi[d]] = tw[d]
        else:
            r = self.ghost_ratio[d]
            b[gi[d]] = (1.0 + r) * tw[d]
            rows.append(gi[d])
            cols.append(col[gs[d]])
            vals.append(-r)
        rows.append(gi[s])
        cols.append(col[gs[s]])
        vals.append(np.ones(int(s.sum())))
        E = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(n, na))
        L = op.pair_weights_matrix(self.g, self.offsets, self.indices, scale=1.0 / self.rho_c)
        La = L[self.active_index]
        return (La @ E).tocsr(), La @ b

    # -- time step -----------------------------------------------------------------------
    def stable_dt(self) -> float:
        """Explicit limit dt = 2 / max_i (|A_ii| + sum_{j != i} |A_ij|) of eq. (2).

        Gershgorin: every eigenvalue of A lies in a disc of centre A_ii and radius
        sum_{j != i} |A_ij|, and forward Euler and Heun are stable for real eigenvalues in
        [-2/dt, 0].  A includes the ghost rules (an antisymmetric ghost adds -r g to its
        source's column).  Interior rows give 1 / (sum_j g_ij / (rho c)_i), i.e.
        dt = C rho c dx^2 / k on a lattice; ``diagnostics`` reports C.

        Computed with the conductances (at the build and at every :meth:`refresh`) by an
        O(pairs) numba pass over the pair weights, without assembling A (the Cleary form:
        in the conductance pass itself, :func:`~sphfem.heat.conduction.cleary_refresh`;
        the corrected form: :func:`~sphfem.heat.conduction.gershgorin_rows`); it equals
        the assembled matrix's value (:meth:`_gershgorin_dt`) to round-off (4e-16
        measured, ``tests/test_heat.py``).
        """
        return self._stable_dt

    def gershgorin_rows(self) -> np.ndarray:
        """|A_ii| + sum_{j != i} |A_ij| of every active row of eq. (2), from the pair pass
        of the last build or refresh (the rows whose maximum :meth:`stable_dt` uses)."""
        return self._rows[self.active_index].copy()

    def _gershgorin_dt(self) -> float:
        """The bound of :meth:`stable_dt` from the assembled sparse A of :meth:`matrix`
        (the reference for the pair pass; O(pairs) too, but with scipy's assembly cost)."""
        if self.active_index.size == 0:
            return np.inf
        A, _ = self.matrix()
        diag = A.diagonal()
        rowabs = np.asarray(abs(A).sum(axis=1)).ravel()
        s = np.abs(diag) + (rowabs - np.abs(diag))
        smax = float(s.max())
        return 2.0 / smax if smax > 0 else np.inf

    def boundary_heat_rate(self, T: np.ndarray) -> float:
        """Heat entering the active particles from ghosts and held particles [W]:
        sum_a V_a sum_{j not active} g_aj (T_j - T_a) (ghosts must be up to date).

        With the Cleary form the active-active exchanges cancel pairwise, so
        d/dt sum m c T equals this to round-off; see :class:`EnergyLedger`.
        """
        q = op.apply_pair_weights(T, self.g_outside, self.offsets, self.indices)
        return float(np.dot(self._vol_active, q[self.active_index]))

    def energy(self, T: np.ndarray, m: np.ndarray, c: np.ndarray) -> float:
        """Thermal energy sum_i m_i c_i T_i over the active particles [J]."""
        a = self.active
        return float(np.sum(m[a] * c[a] * T[a]))


@njit(cache=True)
def _changed(x, vol, x_ref, vol_ref):
    """Per particle: position or volume differs from the reference (exact comparison)."""
    n, dim = x.shape
    out = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        c = vol[i] != vol_ref[i]
        for a in range(dim):
            c = c or x[i, a] != x_ref[i, a]
        out[i] = c
    return out
