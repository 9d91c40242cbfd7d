"""Surface ripples of the 2D CSF droplet (issue 17).

With c0 below the capillary wave speed at the kernel scale, sqrt(2 pi sigma / (rho h)),
the particle-scale capillary waves are supersonic and the droplet's surface grows ripples:
at R/dx = 40 (c0 = 2.68 m/s from the Laplace rule, c_cap = 3.47 m/s) the rms radial
deviation from the l <= 4 shape grew from < 0.01 dx to > 1 dx between 1.2 and 1.6 Rayleigh
periods and the run stopped on the speed guard.  ``droplet_c0`` now includes c_cap.

* fast: :func:`surface_ripple` is ~0 for any smooth shape of the drop (l <= 4) and measures
  a particle-scale zig-zag of amplitude a as ~a / sqrt(2);
* slow: the R/dx = 40 droplet runs 1.8 periods with the ripple bounded and not growing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sphfem.fluid.setup import droplet_packing
from sphfem.fluid.surface_tension_csf import capillary_wave_speed
from sphfem.validation.fluid import droplet_c0, run_droplet, surface_ripple


def _outer_ring_deformed(n, amp_l2, zigzag):
    Rd = 1.0
    dx = Rd / n
    x = droplet_packing(2, Rd, dx)
    r = np.hypot(x[:, 0], x[:, 1])
    th = np.arctan2(x[:, 1], x[:, 0])
    outer = r > Rd - dx
    k = np.arange(len(x))
    r = r * (1 + amp_l2 * np.cos(2 * th))  # a smooth l = 2 shape
    r[outer] += zigzag * dx * np.where(k[outer] % 2 == 0, 1.0, -1.0)
    return np.column_stack([r * np.cos(th), r * np.sin(th)]), dx


def test_ripple_measure_ignores_the_shape_and_sees_particle_noise():
    x, dx = _outer_ring_deformed(20, 0.1, 0.0)
    assert surface_ripple(x, dx) < 0.02
    x, dx = _outer_ring_deformed(20, 0.1, 0.2)
    # the outermost particle per bin: mostly the outward-displaced ones -> well above 0
    assert surface_ripple(x, dx) > 0.05


def test_droplet_c0_is_at_least_the_capillary_wave_speed():
    sigma, rho, Rd = 0.072, 1000.0, 1e-3
    for n in (10, 20, 40, 80):
        h = 1.5 * Rd / n
        c0 = droplet_c0(2, sigma, rho, Rd, 0.0, h=h)
        assert c0 >= capillary_wave_speed(sigma, rho, h)
        assert c0 >= math.sqrt(100 * sigma / (rho * Rd))
    # the capillary step limit 0.25 sqrt(rho h^3/(2 pi sigma)) equals 0.25 h / c_cap
    h = 3.75e-5
    assert 0.25 * math.sqrt(rho * h**3 / (2 * math.pi * sigma)) == pytest.approx(
        0.25 * h / capillary_wave_speed(sigma, rho, h), rel=1e-12)


@pytest.mark.slow
def test_csf_droplet_at_40_layers_grows_no_ripples():
    Tm, T, s, msg, Dn, extra = run_droplet(2, 40, "csf", periods=1.8)
    assert msg == "completed"
    assert abs(Tm / T - 1) < 0.05
    assert extra["ripple_late_over_dx"] < 0.05
    assert extra["ripple_late_over_dx"] < 1.5 * extra["ripple_early_over_dx"] + 0.02
