"""The analysis helpers of benchmarks/pysph/time_to_solution.py (no PySPH, no solver run):
front errors against the digitised experiments, the arrival time at the obstacle, and the
3D geometry mirroring PySPH's DamBreak3DGeometry lattice."""

from __future__ import annotations

import importlib
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from sphfem.fluid.setup import lattice

HERE = Path(__file__).resolve().parents[1] / "benchmarks" / "pysph"


@pytest.fixture(scope="module")
def tts():
    sys.path.insert(0, str(HERE))
    try:
        return importlib.import_module("time_to_solution")
    finally:
        sys.path.remove(str(HERE))


def _front_from_TZ(T, Z, L=1.0):
    """(t, front) samples from the dimensionless (T, Z) with T = t sqrt(2 g / L)."""
    s = math.sqrt(2 * 9.81 / L)
    return [(t / s, z * L) for t, z in zip(T, Z, strict=True)]


def test_front_error_zero_on_the_data_and_exact_for_a_uniform_excess(tts):
    ko = np.array(tts.KOSHIZUKA_OKA)
    T = np.union1d(np.linspace(0.0, 3.5, 71), ko[:, 0])  # samples at the data times too
    Z = np.interp(T, ko[:, 0], ko[:, 1])  # piecewise linear through the data points
    e = tts.front_errors_2d(_front_from_TZ(T, Z), 1.0)
    assert e["koshizuka_oka"] < 1e-12
    # Z 5 % above the data at every sample time: relative L2 distance exactly 5 %
    e = tts.front_errors_2d(_front_from_TZ(T, 1.05 * Z), 1.0)
    assert e["koshizuka_oka"] == pytest.approx(0.05, rel=1e-9)


def test_front_error_only_over_the_data_the_run_reached(tts):
    T = np.linspace(0.0, 2.0, 201)  # stops before the last experimental times
    e = tts.front_errors_2d(_front_from_TZ(T, 1.0 + T), 1.0)
    ko = np.array([d for d in tts.KOSHIZUKA_OKA if d[0] <= 2.0])
    ref = math.sqrt(np.sum((1.0 + ko[:, 0] - ko[:, 1]) ** 2) / np.sum(ko[:, 1] ** 2))
    assert e["koshizuka_oka"] == pytest.approx(ref, rel=1e-12)
    assert e["Z_at_T3"] is None


def test_arrival_time_interpolated_between_samples(tts):
    # front x = 1.2 + 3 t: reaches x = 2.41 at t = 1.21 / 3 exactly (linear samples)
    front = [(t, 1.2 + 3.0 * t) for t in np.arange(0.0, 0.6, 0.007)]
    r = tts.arrival_3d(front, 2.41, 0.55)
    assert r["t_arrival"] == pytest.approx(1.21 / 3.0, rel=1e-12)
    lo, hi = (T / math.sqrt(9.81 / 0.55) for T in tts.KLEEFSMAN_P1_RISE)
    assert r["t_exp"] == pytest.approx(0.5 * (lo + hi))
    assert r["arrival_rel_err"] == pytest.approx(abs(1.21 / 3.0 - r["t_exp"]) / r["t_exp"])
    assert tts.arrival_3d(front[:3], 2.41, 0.55)["t_arrival"] is None  # never reached


@pytest.mark.parametrize("dx", [0.02, 0.04])
def test_3d_boxes_hold_pysph_particle_counts(tts, dx):
    """PySPH's DamBreak3DGeometry puts particles at multiples of dx (x, z) and at
    -0.5 + k dx (y): fluid 0 < x <= 1.228, |y| < 0.5, 0 < z <= 0.55; obstacle
    2.42 <= x <= 2.58, |y| <= 0.2, 0 < z <= 0.161.  Count those points directly."""
    b = tts.pysph_3d_boxes(dx)
    k = np.arange(-5, int(4 / dx))
    xs, zs, ys = k * dx, k * dx, -0.5 + k * dx
    e = 1e-9

    def count(xc, yc, zc):
        return int(np.count_nonzero(xc(xs))) * int(np.count_nonzero(yc(ys))) * int(
            np.count_nonzero(zc(zs)))

    n_fluid = count(lambda x: (x > e) & (x <= 1.228 + e), lambda y: np.abs(y) < 0.5 - e,
                    lambda z: (z > e) & (z <= 0.55 + e))
    n_obst = count(lambda x: (x >= 2.42 - e) & (x <= 2.58 + e),
                   lambda y: np.abs(y) <= 0.2 + e, lambda z: (z > e) & (z <= 0.161 + e))
    assert lattice(*b["fluid"], dx).shape[0] == n_fluid
    assert lattice(*b["obstacle"], dx).shape[0] == n_obst
    # the lattice boxes' points are PySPH's points (cell centres at the same places)
    xf = lattice(*b["fluid"], dx)
    assert np.allclose(np.round(xf[:, 0] / dx), xf[:, 0] / dx)
    assert np.allclose(np.round((xf[:, 1] + 0.5) / dx), (xf[:, 1] + 0.5) / dx)
