"""The banded Cholesky factorisation of the transient substrate heat (sphfem.fem.heat_transient):
the same temperatures as the SuperLU path to round-off over a sequence of steps whose Robin
conductances and step sizes change (every step a new factorisation), and the choice of
"auto" by the reverse Cuthill-McKee half-bandwidth."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from sphfem.fem.heat_transient import (
    BAND_MAX,
    BandedCholesky,
    TransientHeat,
    band_order,
    graded_mesh,
    lower_band,
)

K, RHO, C = 10.0, 3950.0, 900.0  # alumina of the droplet scene
T0, T_F = 293.15, 373.15
#: round-off bound on the difference of the two factorisations, relative to the largest
#: temperature change (both are backward-stable solves of an SPD system whose condition
#: number here is ~1e4: 1e-16 * 1e4 with room)
RTOL = 1e-10


def droplet_mesh(axisymmetric=True, n_lat=60):
    """The droplet job's heat mesh in miniature: 0.08 um first cell growing by 1.2 to a
    depth of 19 um, n_lat lateral cells of 0.78 um."""
    return graded_mesh([(0.0, n_lat * 0.78e-6)], 19e-6, 0.08e-6, 1.2, h_lateral=0.78e-6,
                       axisymmetric=axisymmetric)


def test_banded_cholesky_solves_as_spsolve():
    th = TransientHeat(droplet_mesh(), K, RHO, C, T0, axisymmetric=True)
    A = (th.M / 3e-8 + th.K).tocsr()
    perm, w = band_order(A)
    assert w == th.bandwidth <= BAND_MAX
    b = np.random.default_rng(0).normal(size=A.shape[0])
    x = BandedCholesky(lower_band(A, perm, w), perm).solve(b)
    y = spsolve(A.tocsc(), b)
    assert np.abs(x - y).max() < 1e-13 * np.abs(y).max()
    with pytest.raises(np.linalg.LinAlgError):
        BandedCholesky(lower_band(-A, perm, w), perm)
    with pytest.raises(ValueError, match="half-bandwidth"):
        lower_band(A, perm, w - 1)


@pytest.mark.parametrize("dirichlet", [None, {"bottom": T0}])
def test_banded_steps_equal_splu_steps(dirichlet):
    """A wetted patch that grows and whose conductance thins, at coupling steps of varying
    size (the droplet job's pattern: a new factorisation at every step): the banded and
    the SuperLU runs agree to RTOL of the largest temperature rise, and both keep the
    energy ledger to round-off."""
    runs = {}
    for factor in ("banded", "splu"):
        th = TransientHeat(droplet_mesh(), K, RHO, C, T0, axisymmetric=True,
                           dirichlet=dirichlet, factor=factor)
        assert th.factor == factor
        r = th.surface_points()[:, 0]
        for n in range(12):
            dt = 6e-8 * (1.0 + 0.3 * np.sin(n))
            wet = r < (5 + 3 * n) * 0.78e-6
            h = np.where(wet, 0.6 / np.sqrt(1.5e-7 * dt * (n + 1)), 0.0)
            th.step(dt, robin=(h * th.surface_area, T_F))
        assert th.factorisations == 12
        runs[factor] = th
    a, b = runs["banded"], runs["splu"]
    rise = np.abs(b.T - T0).max()
    assert rise > 10.0
    assert np.abs(a.T - b.T).max() < RTOL * rise
    assert abs(a.heat_in - b.heat_in) < RTOL * abs(b.heat_in)
    if dirichlet is None:
        assert abs(a.energy_residual()) < 1e-9 * abs(a.heat_in)


def test_auto_picks_the_band_only_when_narrow():
    assert TransientHeat(droplet_mesh(), K, RHO, C, T0, axisymmetric=True).factor == "banded"
    # a 3D graded block: the RCM band spans a whole lateral layer (> BAND_MAX)
    m3 = graded_mesh([(0.0, 12e-6), (0.0, 12e-6)], 4e-6, 0.5e-6, 1.3, h_lateral=1e-6)
    th = TransientHeat(m3, K, RHO, C, T0)
    assert th.bandwidth > BAND_MAX and th.factor == "splu"
    with pytest.raises(ValueError, match="factor"):
        TransientHeat(droplet_mesh(), K, RHO, C, T0, factor="cholmod")
    # the pattern the band order is taken from holds every matrix of eq. (1)
    A = (th.M / 1e-8 + th.K + sp.eye(th.basis.N)).tocsr()
    assert band_order(A)[1] == th.bandwidth
