"""Pair conductances of the SPH heat equation rho c dT/dt = div(k grad T).

Both discretisations are stored as one conductance per neighbour pair, so that

    rho_i c_i dT_i/dt = sum_j g_ij (T_j - T_i)                                   (1)

is :func:`sphfem.operators.apply_pair_weights` divided by rho_i c_i, and the implicit
matrix is :func:`sphfem.operators.pair_weights_matrix` with the same ``g``.

* ``cleary`` -- Cleary (1998), Cleary & Monaghan (1999); Park (2019) eq. 2.68 / 2.97:
      g_ij = k_ij w_ij,   k_ij = 2 k_i k_j / (k_i + k_j)  (harmonic mean),
      w_ij = -2 V_j (dW/dr)(r_ij) / r_ij    (Brookshaw weights, >= 0).
  The 4 k_i k_j/(k_i + k_j) of eq. 2.97 is 2 k_ij.  With equal kernels V_i g_ij = V_j g_ji,
  so the heat m_i c_i dT_i/dt = V_i sum_j g_ij (T_j - T_i) leaving i is what j receives:
  sum_i m_i c_i T_i is conserved to round-off when no ghost supplies heat.
* ``fatehi_manzari`` -- Park (2019) eq. 2.101 idea with the Fatehi & Manzari (2011)
  corrected weights (exact for quadratic T in one material):
      g_ij = k_ij w^FM_ij
  Where the correction matrix of particle i is singular the weights fall back to the
  Brookshaw ones (``ok[i] = False``, counted by the caller).  Not pairwise symmetric, so
  energy is conserved only to truncation error.

  Positivity limiter (optional, on by default in the heat module): on disordered particles
  some corrected weights are negative, and the explicit scheme can then grow without bound
  at any step (eigenvalues with positive real part; 20 % random disorder blows up within
  100 steps).  A row with a negative weight is blended with its Brookshaw row,
      w_ij <- (1 - beta_i) w^FM_ij + beta_i w^B_ij,
      beta_i = max_{j: w^FM_ij < 0} (-w^FM_ij) / (w^B_ij - w^FM_ij),
  the smallest blend with every weight >= 0.  Each row is then a positive combination of
  differences, so its Gershgorin disc lies in the left half-plane, Heun at the Gershgorin
  step is stable and keeps the maximum principle.  Rows whose weights are all >= 0
  (lattice interiors) keep the exact corrected weights.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sphfem import operators as op
from sphfem.heat.stepping import PARALLEL_MIN
from sphfem.kernels import kernel_dfdq
from sphfem.neighbors import min_image

LAPLACIANS = ("cleary", "fatehi_manzari")


@njit(cache=True, parallel=True)
def harmonic_conductance(w, k, offsets, indices):
    """g_ij = w_ij * 2 k_i k_j / (k_i + k_j) (zero where k_i + k_j == 0)."""
    n = offsets.shape[0] - 1
    g = np.empty_like(w)
    for i in prange(n):
        ki = k[i]
        for jj in range(offsets[i], offsets[i + 1]):
            kj = k[indices[jj]]
            s = ki + kj
            g[jj] = w[jj] * (2.0 * ki * kj / s) if s > 0.0 else 0.0
    return g


@njit(cache=True, parallel=True)
def positivity_limit(w, wb, offsets, limited):
    """Blend each row of ``w`` holding a negative weight with the non-negative row ``wb``
    just enough that every weight is >= 0 (module docstring); in place.  ``limited[i]`` is
    set to the blend factor beta_i (0 where the row was left alone)."""
    n = offsets.shape[0] - 1
    for i in prange(n):
        beta = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            if w[jj] < 0.0:
                beta = max(beta, -w[jj] / (wb[jj] - w[jj]))
        limited[i] = beta
        if beta > 0.0:
            for jj in range(offsets[i], offsets[i + 1]):
                w[jj] = max((1.0 - beta) * w[jj] + beta * wb[jj], 0.0)


def pair_conductances(k, x, vol, offsets, indices, R, sigma, kind, period,
                      laplacian: str = "cleary", cond_max: float = op.COND_MAX,
                      plain_rows=None, limiter_rows=None):
    """Conductances g_ij of eq. (1) for every neighbour pair, the correction mask and the
    limiter's blend factors.

    Returns ``(g, ok, beta)``: ``ok[i]`` is False where the Fatehi-Manzari correction of
    particle ``i`` was singular and the plain weights were used (always True for
    ``cleary``).  ``plain_rows`` (bool per particle) forces the plain weights on those rows
    of the corrected form (free-surface particles, see
    :class:`sphfem.heat.system.HeatSystem`); they are not counted in ``ok``.
    ``limiter_rows`` (bool per particle, or None for no limiter) are the rows the
    positivity limiter may blend; ``beta[i]`` is its blend factor (0: exact weights kept).
    """
    args = (x, vol, offsets, indices, R, sigma, kind, period)
    beta = np.zeros(x.shape[0])
    if laplacian == "cleary":
        w = op.laplacian_weights_brookshaw(*args)
        ok = np.ones(x.shape[0], dtype=bool)
    elif laplacian == "fatehi_manzari":
        w, ok = op.laplacian_weights_corrected(*args, cond_max=cond_max)
        wb = None
        if plain_rows is not None and np.any(plain_rows):
            wb = op.laplacian_weights_brookshaw(*args)
            rows = np.repeat(np.asarray(plain_rows, bool), np.diff(offsets))
            w = np.where(rows, wb, w)
        if limiter_rows is not None and np.any(limiter_rows):
            wb = op.laplacian_weights_brookshaw(*args) if wb is None else wb
            rows = np.repeat(~np.asarray(limiter_rows, bool), np.diff(offsets))
            w = np.ascontiguousarray(w)
            w_keep = w[rows].copy()
            positivity_limit(w, wb, offsets, beta)
            w[rows] = w_keep
            beta[~np.asarray(limiter_rows, bool)] = 0.0
    else:
        raise ValueError(f"unknown laplacian {laplacian!r}; expected one of {LAPLACIANS}")
    return harmonic_conductance(w, np.ascontiguousarray(k, dtype=np.float64), offsets,
                                indices), ok, beta


def conduction_rate(T, g, offsets, indices, rho_c):
    """dT_i/dt = sum_j g_ij (T_j - T_i) / (rho_i c_i) for every particle (eq. 1)."""
    return op.apply_pair_weights(T, g, offsets, indices) / rho_c


# -- per-step refresh for moving particles (see HeatSystem.refresh) ------------------------
@njit(cache=True, inline="always")
def _row_gershgorin(i, g, offsets, indices, inv_rc_i, active, rule_src, rule_coef):
    """sum_a |A_ia| of row i of A = S L E (eq. 2 of :mod:`sphfem.heat.system`) from the
    conductances of row i: the diagonal -sum_j g_ij / (rho c)_i, +g_ij / (rho c)_i in the
    column of an active neighbour j, rule_coef_j g_ij / (rho c)_i in the column of the
    source rule_src_j of a ghost j with a rule on active temperatures (antisymmetric
    Dirichlet: -r, insulated: +1); held particles and "hold" Dirichlet ghosts add to the
    diagonal only.  Entries of one column are summed before taking |.| (a ghost whose
    source is i itself or a listed neighbour), as in the assembled sparse matrix."""
    diag = 0.0
    off = 0.0
    nrule = 0
    for jj in range(offsets[i], offsets[i + 1]):
        j = indices[jj]
        v = g[jj] * inv_rc_i
        diag -= v
        if j == i:
            diag += v
        elif active[j]:
            off += abs(v)
        elif rule_src[j] >= 0:
            nrule += 1
    if nrule == 0:
        return abs(diag) + off
    # rare rows next to ghosts with rules: merge the entries of equal columns
    m = offsets[i + 1] - offsets[i] + 1
    cols = np.empty(m, np.int64)
    vals = np.empty(m)
    isrule = np.zeros(m, np.bool_)
    cols[0] = i
    vals[0] = diag
    cnt = 1
    for jj in range(offsets[i], offsets[i + 1]):
        j = indices[jj]
        if j == i:
            continue
        if active[j]:
            cols[cnt] = j
            vals[cnt] = g[jj] * inv_rc_i
            cnt += 1
        elif rule_src[j] >= 0:
            cols[cnt] = rule_src[j]
            vals[cnt] = rule_coef[j] * (g[jj] * inv_rc_i)
            isrule[cnt] = True
            cnt += 1
    for q in range(cnt):
        if not isrule[q]:
            continue
        c = cols[q]
        tgt = -1
        for p in range(cnt):  # the diagonal or an active neighbour's column (unique)
            if cols[p] == c and not isrule[p]:
                tgt = p
                break
        if tgt < 0:
            for p in range(q):  # else the first ghost entry of the same source
                if cols[p] == c:
                    tgt = p
                    break
        if tgt >= 0:
            vals[tgt] += vals[q]
            vals[q] = 0.0
    s = 0.0
    for p in range(cnt):
        s += abs(vals[p])
    return s


@njit(cache=True, inline="always")
def _gershgorin_row(i, g, offsets, indices, inv_rc, active, rule_src, rule_coef, g_out):
    for jj in range(offsets[i], offsets[i + 1]):
        g_out[jj] = 0.0 if active[indices[jj]] else g[jj]
    if not active[i]:
        return 0.0
    return _row_gershgorin(i, g, offsets, indices, inv_rc[i], active, rule_src, rule_coef)


@njit(cache=True, parallel=True)
def _gershgorin_rows_parallel(g, offsets, indices, inv_rc, active, rule_src, rule_coef, g_out):
    n = offsets.shape[0] - 1
    s = np.zeros(n)
    for i in prange(n):
        s[i] = _gershgorin_row(i, g, offsets, indices, inv_rc, active, rule_src, rule_coef,
                               g_out)
    return s


@njit(cache=True)
def _gershgorin_rows_serial(g, offsets, indices, inv_rc, active, rule_src, rule_coef, g_out):
    """Serial twin of :func:`_gershgorin_rows_parallel` (separate functions: numba's on-disk
    cache does not tell two compilations of one function with different ``parallel``
    apart)."""
    n = offsets.shape[0] - 1
    s = np.zeros(n)
    for i in range(n):
        s[i] = _gershgorin_row(i, g, offsets, indices, inv_rc, active, rule_src, rule_coef,
                               g_out)
    return s


@njit(cache=True)
def gershgorin_rows(g, offsets, indices, inv_rc, active, rule_src, rule_coef, g_out):
    """sum_a |A_ia| per particle (0 on rows that are not active; :func:`_row_gershgorin`)
    in one O(pairs) pass; also fills ``g_out`` (g where the neighbour is not active, else
    0).  Threaded from :data:`~sphfem.heat.stepping.PARALLEL_MIN` particles."""
    if offsets.shape[0] - 1 >= PARALLEL_MIN:
        return _gershgorin_rows_parallel(g, offsets, indices, inv_rc, active, rule_src,
                                         rule_coef, g_out)
    return _gershgorin_rows_serial(g, offsets, indices, inv_rc, active, rule_src, rule_coef,
                                   g_out)


@njit(cache=True, inline="always", fastmath=op.FASTMATH)
def _cleary_row(i, k, x, vol, offsets, indices, R, sigma, kind, period, inv_rc, active,
                rule_src, rule_coef, g, g_out, changed, rows_prev):
    """Row i of :func:`cleary_refresh`; returns its Gershgorin sum (0 if not active),
    accumulated in the same loop unless a ghost with a rule is a neighbour.  A pair of two
    particles that ``changed`` marks False keeps its conductance in ``g``; a row without any
    changed particle returns ``rows_prev`` (its sum of the last call) untouched."""
    ki = k[i]
    irc = inv_rc[i]
    R2 = R * R
    c0 = -2.0 * sigma / R
    inv_R = 1.0 / R
    diag = 0.0
    off = 0.0
    nrule = 0
    ci = changed[i]
    if not ci:  # a row with no changed particle keeps its conductances and its sum
        quiet = True
        for jj in range(offsets[i], offsets[i + 1]):
            if changed[indices[jj]]:
                quiet = False
                break
        if quiet:
            return rows_prev
    for jj in range(offsets[i], offsets[i + 1]):
        j = indices[jj]
        if ci or changed[j]:
            d2 = 0.0
            for a in range(x.shape[1]):
                dd = min_image(x[j, a] - x[i, a], period[a])
                d2 += dd * dd
            gv = 0.0
            if 0.0 < d2 < R2:  # dW/dr = 0 beyond R: skin pairs cost no kernel evaluation
                kj = k[j]
                ks = ki + kj
                if ks > 0.0:
                    d = np.sqrt(d2)
                    gv = (c0 * vol[j] * kernel_dfdq(d * inv_R, kind) / d) * (2.0 * ki * kj
                                                                               / ks)
            g[jj] = gv
        else:  # neither end moved nor changed volume: the conductance stands
            gv = g[jj]
        if active[j]:
            g_out[jj] = 0.0
            if j != i:
                v = gv * irc
                diag -= v
                off += abs(v)
        else:
            g_out[jj] = gv
            diag -= gv * irc
            if rule_src[j] >= 0:
                nrule += 1
    if not active[i]:
        return 0.0
    if nrule == 0:
        return abs(diag) + off
    return _row_gershgorin(i, g, offsets, indices, irc, active, rule_src, rule_coef)


@njit(cache=True, parallel=True, fastmath=op.FASTMATH)
def _cleary_refresh_parallel(k, x, vol, offsets, indices, R, sigma, kind, period, inv_rc,
                             active, rule_src, rule_coef, g, g_out, rows, changed):
    n = x.shape[0]
    for i in prange(n):
        rows[i] = _cleary_row(i, k, x, vol, offsets, indices, R, sigma, kind, period, inv_rc,
                              active, rule_src, rule_coef, g, g_out, changed, rows[i])
    best = 0.0
    for i in range(n):
        best = max(best, rows[i])
    return best


@njit(cache=True, fastmath=op.FASTMATH)
def _cleary_refresh_serial(k, x, vol, offsets, indices, R, sigma, kind, period, inv_rc,
                           active, rule_src, rule_coef, g, g_out, rows, changed):
    """Serial twin of :func:`_cleary_refresh_parallel`."""
    best = 0.0
    for i in range(x.shape[0]):
        rows[i] = _cleary_row(i, k, x, vol, offsets, indices, R, sigma, kind, period, inv_rc,
                              active, rule_src, rule_coef, g, g_out, changed, rows[i])
        best = max(best, rows[i])
    return best


@njit(cache=True)
def cleary_refresh(k, x, vol, offsets, indices, R, sigma, kind, period, inv_rc, active,
                   rule_src, rule_coef, g, g_out, rows, changed):
    """The Cleary conductances from the current positions, in place, in one pass over the
    pairs: g_ij = 2 k_i k_j / (k_i + k_j) * (-2 V_j (dW/dr)(r_ij) / r_ij) (0 for
    r_ij >= R, where dW/dr vanishes, so a Verlet-skin list gives the g of an exact one),
    ``g_out`` (g to non-active neighbours) and ``rows`` (the Gershgorin sums of
    :func:`gershgorin_rows`, 0 on rows that are not active), whose maximum it returns.
    ``changed`` (bool per particle): pairs of two unchanged particles (same position and
    volume as at the last call, on the same list) keep their ``g``; pass all True the first
    time.  Threaded from :data:`~sphfem.heat.stepping.PARALLEL_MIN` particles (below it thread
    start-up costs more than the pass: ms on a loaded host against 0.2 ms for the pass on
    800 particles)."""
    if x.shape[0] >= PARALLEL_MIN:
        return _cleary_refresh_parallel(k, x, vol, offsets, indices, R, sigma, kind, period,
                                        inv_rc, active, rule_src, rule_coef, g, g_out, rows,
                                        changed)
    return _cleary_refresh_serial(k, x, vol, offsets, indices, R, sigma, kind, period,
                                  inv_rc, active, rule_src, rule_coef, g, g_out, rows,
                                  changed)
