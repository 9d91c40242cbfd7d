"""Criteria of the fluid validation cases that must be able to fail (issue 14)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sphfem.validation.fluid import cauchy_ratio, extrapolated_growth


def test_quick_hydrostatic_speed_is_carried_to_the_full_resolution():
    """The lattice start's quick figures (max speed 0.0058, 0.0084 sqrt(gH) at H/20, H/30)
    passed the 0.01 limit while the full run failed it (0.0159 at H/80); carried to H/80
    with their growth they fail too.  A decrease earns no credit; at H/80 nothing changes."""
    v = extrapolated_growth((20, 30), (0.0058, 0.0084), 80)
    assert v > 0.01
    assert v == pytest.approx(0.0084 * (80 / 30) ** (math.log(0.0084 / 0.0058) / math.log(1.5)))
    assert extrapolated_growth((20, 30), (0.004, 0.003), 80) == 0.003
    assert extrapolated_growth((20, 40, 80), (0.001, 0.002, 0.004), 80) == 0.004


def test_dambreak_self_convergence_catches_a_growing_error():
    """Front curves Z_n = Z* + C/n converge (ratio 1/2 for doubling); Z_n = Z* + C n (an
    error growing with resolution) give ratio 2 and fail the criterion (<= 1)."""
    T = np.linspace(0.0, 3.2, 50)
    Zs = 1.0 + 1.3 * T
    conv = {n: (T, Zs + 0.5 * T / n) for n in (20, 40, 80)}
    grow = {n: (T, Zs + 0.002 * n * T) for n in (20, 40, 80)}
    Te = np.linspace(0.25, 3.0, 12)
    assert cauchy_ratio(conv, Te) == pytest.approx(0.5)
    assert cauchy_ratio(grow, Te) == pytest.approx(2.0)
