"""The contact interface's removal of heat from the fluid (coupling.heat_interface, eq. 5'
and 5''): conservative to round-off, (5) when a node's particles share one temperature,
and no particle cooled below the surface's temperature (the maximum principle)."""

from __future__ import annotations

import numpy as np
import pytest

from coupling.heat_interface import ContactHeatInterface, removal


def _pairs():
    # node 0: particles 0, 1, 2; node 1: particles 2, 3 (weights sum to 1 per node)
    rows = np.array([0, 0, 0, 1, 1])
    cols = np.array([0, 1, 2, 2, 3])
    w = np.array([0.5, 0.3, 0.2, 0.4, 0.6])
    return rows, cols, w


def test_removal_is_the_weights_for_one_temperature_and_conserves():
    rows, cols, w = _pairs()
    heat = np.array([2.0e-6, -0.5e-6])
    Ts = np.array([300.0, 300.0])
    T = np.full(4, 350.0)  # node 0 gives heat, node 1 takes heat (its particles hotter):
    dE = removal(heat, rows, cols, w, T, Ts, 4)  # share by w alone at one temperature
    assert dE == pytest.approx(np.bincount(cols, weights=w * heat[rows], minlength=4),
                               rel=1e-14)
    T = np.array([350.0, 320.0, 300.0, 290.0])
    dE = removal(heat, rows, cols, w, T, Ts, 4)
    assert dE.sum() == pytest.approx(heat.sum(), rel=1e-14)
    # node 0 (into the substrate) takes nothing from particle 2 (at the surface's
    # temperature); node 1 (out of it) gives only to particle 3 (below it)
    assert dE[0] / dE[1] == pytest.approx(0.5 * 50.0 / (0.3 * 20.0), rel=1e-12)
    assert dE[2] == 0.0
    assert dE[3] == pytest.approx(heat[1], rel=1e-14)
    # no particle of a node with any excess: the weights
    T = np.full(4, 300.0)
    assert removal(heat, rows, cols, w, T, Ts, 4) == pytest.approx(
        np.bincount(cols, weights=w * heat[rows], minlength=4), rel=1e-14)


def test_conductance_capped_so_no_particle_crosses_the_surface():
    """Eq. (5''): with a tiny particle (a ring next to the axis), the nodes it feeds are
    scaled until dt sum_a w_ai hA_a <= m_i c_i; the others keep theirs."""
    rows, cols, w = _pairs()
    itf = ContactHeatInterface.__new__(ContactHeatInterface)
    itf.capped = 0
    hA = np.array([1.0, 2.0])  # W/K
    cap = np.array([1.0, 1.0, 0.01, 1.0])  # J/K
    dt = 0.1
    itf._cap_conductance(hA, rows, cols, w, dt, cap, 4)
    load = np.bincount(cols, weights=dt * w * hA[rows], minlength=4)
    assert np.all(load <= cap * (1 + 1e-12))
    assert load[2] == pytest.approx(cap[2], rel=1e-12)  # particle 2 feeds both nodes
    assert itf.capped == 2
    hA2 = np.array([1.0, 2.0])
    itf._cap_conductance(hA2, rows, cols, w, dt, np.ones(4), 4)  # nothing to cap
    assert hA2.tolist() == [1.0, 2.0] and itf.capped == 2
    # with the cap, the removal of the implicit heat keeps every particle above Ts
    T = np.array([350.0, 340.0, 310.0, 330.0])
    Ts = np.array([300.0, 300.0])
    heat = hA * dt * (np.bincount(rows, weights=w * T[cols]) - Ts)
    T_new = T - removal(heat, rows, cols, w, T, Ts, 4) / cap
    assert T_new.min() >= 300.0 - 1e-9
