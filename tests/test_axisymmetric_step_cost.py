"""The axisymmetric droplet job's cheaper step (issue 19): the reorganised passes give the
results of the passes they replace to the bit (benchmarks/README.md, "axisymmetric droplet
job, per-step cost")."""

import numpy as np


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


def test_packed_heat_rates_equal_heat_rates_bitwise():
    """heat_conductances + heat_rates_packed (the pair weights once, the rates of any T from
    them) give heat_rates' rates and Gershgorin bound to the bit, on a jittered ring
    cloud with axis ghosts, a Verlet-skin list (pairs beyond R in the rows) and rings with
    k = 0, for two temperature fields (a Heun step's stages)."""
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
    mom = np.ones(n + gh.n)
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
