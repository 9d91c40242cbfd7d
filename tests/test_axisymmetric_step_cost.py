"""The axisymmetric droplet job's cheaper step (issue 19): the reorganised passes give the
results of the passes they replace to the bit (benchmarks/README.md, "axisymmetric droplet
job, per-step cost")."""

import math

import numpy as np
import pytest


def _ring_cloud(seed=3, n_side=16, dx=0.1, k_zero_below=True):
    rng = np.random.default_rng(seed)
    g = (np.arange(n_side) + 0.5) * dx
    x = np.array(np.meshgrid(g, g - 0.8)).reshape(2, -1).T
    x += rng.uniform(-0.2, 0.2, x.shape) * dx
    x[:, 0] = np.abs(x[:, 0])
    k = rng.uniform(0.5, 2.0, len(x))
    if k_zero_below:
        k[x[:, 1] < -0.4] = 0.0  # rings without conduction take part in no pair
    return x, k, rng


@pytest.mark.parametrize("uniform", [False, True])
def test_packed_heat_rates_equal_heat_rates_bitwise(uniform):
    """heat_conductances + heat_rates_packed (the pair weights once, the rates of any T from
    them) give heat_rates' rates and Gershgorin bound to the bit, on a jittered ring
    cloud with axis ghosts, a Verlet-skin list (pairs beyond R in the rows) and rings with
    k = 0, for two temperature fields (a Heun step's stages); per-ring k and moments, or one
    k and unit moments (the cached factors)."""
    from sphfem import kernels
    from sphfem.heat.axisymmetric import (
        axis_ghosts,
        heat_conductances,
        heat_rates,
        heat_rates_packed,
    )
    from sphfem.neighbors import build_neighbor_list
    from sphfem.particles import FLUID, GHOST

    x, k, rng = _ring_cloud()
    if uniform:
        k[k > 0.0] = 0.6
    dx, R = 0.1, 0.3
    gh = axis_ghosts(x, 1.15 * R)
    n = len(x)
    xa = np.ascontiguousarray(np.vstack([x, gh.x]))
    kind = np.concatenate([np.full(n, FLUID, np.int8), np.full(gh.n, GHOST, np.int8)])
    keep = [0] * (GHOST + 1)
    keep[FLUID] = (1 << FLUID) | (1 << GHOST)
    rl = 1.15 * R
    nl = build_neighbor_list(xa, rl, xa.min(axis=0) - rl, xa.max(axis=0) + rl, np.zeros(2),
                             kind=kind, keep=tuple(keep))
    A = rng.uniform(0.8, 1.2, n) * dx * dx
    inv = 1.0 / (x[:, 0] * 1000.0 * rng.uniform(3000.0, 5000.0, n))
    Aa = np.concatenate([A, A[gh.src]])
    ka = np.concatenate([k, k[gh.src]])
    rc = np.concatenate([x[:, 0], gh.r_cond])
    mom = np.ones(n + gh.n) if uniform else rng.uniform(0.4, 1.1, n + gh.n)
    kc = kernels.kernel_code("wendland_c2")
    sig = kernels.kernel_sigma(kc, 2, R)
    m = nl.indices.shape[0]
    count, pj, pg = np.zeros(n, np.int64), np.zeros(m, np.int64), np.zeros(m)
    g_packed = heat_conductances(xa, Aa, ka, rc, inv, mom, n, nl.offsets, nl.indices, R, sig,
                                 kc, np.zeros(2), count, pj, pg)
    assert count.sum() < m  # the skin's pairs beyond R and the k = 0 pairs are left out
    for _ in range(2):
        T = rng.uniform(280.0, 380.0, n)
        Ta = np.concatenate([T, T[gh.src]])
        ref = np.zeros(n)
        g_ref = heat_rates(xa, Ta, Aa, ka, rc, inv, mom, n, nl.offsets, nl.indices, R, sig, kc,
                           np.zeros(2), ref)
        out = np.full(n, np.nan)
        heat_rates_packed(Ta, inv, n, nl.offsets, count, pj, pg, out)
        assert np.array_equal(out, ref) and g_packed == g_ref
        assert np.abs(ref).max() > 0.0


def test_step_kernels_equal_the_numpy_updates_bitwise():
    """The predictor / corrector loops of AxisymmetricFluid.step, the axis reflection and the
    shifting's inputs give the numpy expressions they replaced to the bit."""
    from sphfem.fluid.axisymmetric import (
        _correct,
        _predict,
        _reflect_axis,
        _shift_inputs,
    )
    from sphfem.particles import FLUID, WALL

    rng = np.random.default_rng(7)
    n = 400
    kind = np.where(rng.random(n) < 0.7, FLUID, WALL).astype(np.int8)
    fl = kind == FLUID
    fi = np.flatnonzero(fl)
    x = rng.normal(size=(n, 2))
    v, acc = rng.normal(size=(n, 2)), rng.normal(size=(n, 2)) * 1e3
    rho, drho = 1000.0 + rng.normal(size=n), rng.normal(size=n) * 1e4
    lam = rng.uniform(0.0, 1.0, n)
    dt, rho0 = 3.7e-7, 1000.0
    # predictor and corrector against the numpy forms (with the surface density hold)
    X, V, Rho = x.copy(), v.copy(), rho.copy()
    v_n, rho_n = V[fl].copy(), Rho[fl].copy()
    X[fl] += 0.5 * dt * V[fl]
    V[fl] += 0.5 * dt * acc[fl]
    Rho[fl] += 0.5 * dt * drho[fl]
    s = fl & (lam < 0.75) & (Rho < rho0)
    Rho[s] = rho0
    x2, v2, rho2 = x.copy(), v.copy(), rho.copy()
    vn2, rhon2 = np.empty((fi.size, 2)), np.empty(fi.size)
    _predict(fi, x2, v2, rho2, acc, drho, 0.5 * dt, vn2, rhon2, lam, math.inf, rho0)
    assert np.array_equal(X, x2) and np.array_equal(V, v2) and np.array_equal(Rho, rho2)
    assert np.array_equal(v_n, vn2) and np.array_equal(rho_n, rhon2)
    V[fl] = v_n + dt * acc[fl]
    Rho[fl] = rho_n + dt * drho[fl]
    s = fl & (lam < 0.75) & (Rho < rho0)
    Rho[s] = rho0
    X[fl] += 0.5 * dt * V[fl]
    _correct(fi, x2, v2, rho2, acc, drho, dt, 0.5 * dt, vn2, rhon2, lam, math.inf, rho0)
    assert np.array_equal(X, x2) and np.array_equal(V, v2) and np.array_equal(Rho, rho2)
    # the hold only within |r| < hold_r (the pair force's axis band)
    x3, v3, rho3 = x.copy(), v.copy(), rho.copy()
    _predict(fi, x3, v3, rho3, acc, drho, 0.5 * dt, vn2, rhon2, lam, 0.5, rho0)
    Rho3 = rho.copy()
    Rho3[fl] += 0.5 * dt * drho[fl]
    s3 = fl & (lam < 0.75) & (Rho3 < rho0) & (np.abs(x3[:, 0]) < 0.5)
    Rho3[s3] = rho0
    assert np.array_equal(Rho3, rho3) and s3.any() and (s & ~s3).any()
    # reflection at the axis and at a wall plane
    zw = 0.1
    neg = fl & (X[:, 0] < 0.0)
    X[neg, 0] *= -1.0
    V[neg, 0] *= -1.0
    below = fl & (X[:, 1] < zw)
    X[below, 1] = 2.0 * zw - X[below, 1]
    V[below, 1] *= -1.0
    _reflect_axis(fi, x2, v2, True, zw, 0.0)
    assert neg.any() and below.any()
    assert np.array_equal(X, x2) and np.array_equal(V, v2)
    # the shifting's inputs (AxisymmetricFluid._shift before)
    gc, B = rng.normal(size=(n, 2)), rng.normal(size=(n, 3))
    gc[:3] = 0.0  # |b| = 0
    Rp = rng.uniform(0.9, 1.1, n)
    b = np.column_stack([B[:, 0] * gc[:, 0] + B[:, 1] * gc[:, 1],
                         B[:, 1] * gc[:, 0] + B[:, 2] * gc[:, 1]])
    nb = np.sqrt((b**2).sum(axis=1))
    nrm = -b / np.where(nb > 0.0, nb, 1.0)[:, None]
    fragment = lam <= 0.2
    near = (lam < 0.75) & ~fragment
    h = 0.5 * Rp
    gcs = gc * (h / h.max())[:, None]
    kind_s = np.where(fragment, WALL, kind).astype(np.int8)
    out = (np.empty((n, 2)), np.empty((n, 2)), np.empty(n, np.bool_), np.empty(n, np.int8))
    hmax, hmin = _shift_inputs(gc, B, lam, kind, Rp, 0.2, out[1], out[0], out[2], out[3])
    assert hmax == h.max() and hmin == h.min()
    assert np.array_equal(out[0], nrm) and np.array_equal(out[1], gcs)
    assert np.array_equal(out[2], near) and np.array_equal(out[3], kind_s)
    # a lower threshold ([fluid] shifting_surface_lambda): fewer rows shifted tangentially
    _shift_inputs(gc, B, lam, kind, Rp, 0.2, out[1], out[0], out[2], out[3], 0.5)
    assert np.array_equal(out[2], (lam < 0.5) & ~fragment)


def test_gradients_pack_the_pairs_within_support():
    """gradients packs, per fluid row and in list order, exactly the list's pairs with
    0 < d_ij < R_ij, with d_ij and f'(d_ij / R_ij) (the pairs forces runs over)."""
    from sphfem import kernels
    from sphfem.fluid.axisymmetric import KEEP, gradients, hoop_ratio
    from sphfem.neighbors import build_neighbor_list
    from sphfem.particles import FLUID, WALL

    rng = np.random.default_rng(11)
    dx = 0.1
    g = (np.arange(12) + 0.5) * dx
    x = np.array(np.meshgrid(g, g)).reshape(2, -1).T + rng.uniform(-0.2, 0.2, (144, 2)) * dx
    kind = np.where(x[:, 1] < 0.25, WALL, FLUID).astype(np.int8)
    m = len(x)
    Rp = np.full(m, 3.0 * dx) * rng.uniform(0.9, 1.1, m)  # varying support: R_ij per pair
    rl = 1.15 * Rp.max()
    nl = build_neighbor_list(x, rl, x.min(axis=0) - rl, x.max(axis=0) + rl, np.zeros(2),
                             kind=kind, keep=KEEP)
    kc = kernels.kernel_code("wendland_c2")
    s2 = kernels.kernel_sigma(kc, 2, 1.0)
    vg = rng.normal(size=(m, 2))
    qv = np.empty(m)
    hoop_ratio(x, vg, qv)
    k = nl.indices.shape[0]
    count, pj, pd, pk = np.zeros(m, np.int64), np.zeros(k, np.int64), np.zeros(k), np.zeros(k)
    z = lambda *s: np.zeros(s)  # noqa: E731
    gradients(x, 1000.0 + rng.normal(size=m), vg, np.full(m, dx * dx), kind, nl.offsets,
              nl.indices, Rp, s2, kc, 0.0, 1e6, 0.2, z(m, 2), z(m, 2), z(m), z(m, 5), z(m),
              z(m, 2), qv, count, pj, pd, pk)
    packed = 0
    for i in range(m):
        o = nl.offsets[i]
        js = nl.indices[o:nl.offsets[i + 1]]
        r = x[js] - x[i]
        d2 = r[:, 0] * r[:, 0] + r[:, 1] * r[:, 1]
        R = 0.5 * (Rp[i] + Rp[js])
        keep = (d2 < R * R) & (d2 != 0.0) if kind[i] == FLUID else np.zeros(len(js), bool)
        c = int(count[i])
        assert c == keep.sum()
        assert np.array_equal(pj[o:o + c], js[keep])
        d = np.sqrt(d2[keep])
        assert np.array_equal(pd[o:o + c], d)
        assert np.array_equal(pk[o:o + c], [kernels.kernel_dfdq(q, kc) for q in d / R[keep]])
        packed += c
    assert 0 < packed < nl.indices.shape[0]
