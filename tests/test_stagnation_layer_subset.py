"""The contact interface advances the thermal layer of the wetted nodes only
(coupling.heat_interface.ContactHeatInterface.step): the layer functions are elementwise,
so a subset of nodes gets exactly the numbers it gets inside the whole surface."""

from __future__ import annotations

import numpy as np
import pytest

from coupling.heat_interface import strained_layer_s2, strained_mean_inv_s
from sphfem.heat.stagnation_layer import gauss_legendre, integrate_layer, viscous_layer_rate

ALPHA, NU = 1.43e-7, 1.0e-6


def _nodes(n=257, seed=5):
    rng = np.random.default_rng(seed)
    s2 = np.where(rng.random(n) < 0.2, 0.0, (3e-7 * rng.random(n)) ** 2)
    a1 = rng.normal(0.0, 4e5, n)  # strains of either sign
    a1[rng.random(n) < 0.1] = 0.0
    h = 1e-6 * (0.5 + rng.random(n))
    dt = 2.3e-9
    tau0 = np.where(rng.random(n) < 0.3, dt * rng.random(n), 0.0)
    return s2, a1, h, tau0, dt


@pytest.mark.parametrize("c", [1, 2])
def test_viscous_layer_on_a_subset(c):
    s2, a1, h, tau0, dt = _nodes()
    full = integrate_layer(s2, tau0, dt, viscous_layer_rate(a1, h, NU, ALPHA, c), ALPHA)
    for idx in (np.flatnonzero(a1 > 0), np.arange(0, s2.size, 7), np.array([3]),
                np.zeros(0, np.int64)):
        sub = integrate_layer(s2[idx], tau0[idx], dt,
                              viscous_layer_rate(a1[idx], h[idx], NU, ALPHA, c), ALPHA)
        assert np.array_equal(sub[0], full[0][idx]) and np.array_equal(sub[1], full[1][idx])


def test_strained_layer_on_a_subset():
    s2, a1, _, tau0, dt = _nodes(seed=8)
    inv = strained_mean_inv_s(s2, a1, ALPHA, tau0, dt)
    end = strained_layer_s2(s2, a1, ALPHA, dt - tau0)
    idx = np.flatnonzero(s2 > 0)
    assert np.array_equal(strained_mean_inv_s(s2[idx], a1[idx], ALPHA, tau0[idx], dt),
                          inv[idx])
    assert np.array_equal(strained_layer_s2(s2[idx], a1[idx], ALPHA, dt - tau0[idx]),
                          end[idx])


def test_gauss_legendre_is_numpys_rule():
    for n in (2, 3, 8):
        g, w = gauss_legendre(n)
        G, W = np.polynomial.legendre.leggauss(n)
        assert np.array_equal(g, G) and np.array_equal(w, W)
        assert gauss_legendre(n)[0] is g and not g.flags.writeable
