"""The Hiemenz/Homann profile table of the strained-viscous contact layer and its J(sigma)
table (sphfem.heat.stagnation_layer.stagnation_profile, _tables) kept on disk: read back
bit for bit equal to the computation, and the files are where sphfem.cache puts them."""

import numpy as np

from sphfem.heat import stagnation_layer as sl


def test_profile_read_back_equals_the_solve(tmp_path, monkeypatch):
    monkeypatch.setenv("SPHFEM_CACHE", str(tmp_path))
    sl.stagnation_profile.cache_clear()
    try:
        first = sl.stagnation_profile(2)
        files = list((tmp_path / "stagnation_profile").glob("*.npy"))
        assert len(files) == 1
        sl.stagnation_profile.cache_clear()
        again = sl.stagnation_profile(2)  # from the file
        solved = sl._solve_profile(2)
        for a, b, c in zip(first, again, solved, strict=True):
            assert np.array_equal(a, c) and np.array_equal(b, c)
        # Homann's f''(0) = 1.3119 (White, Viscous Fluid Flow, sec. 3-8)
        assert abs(solved[2][0] - 1.3119) < 1e-4
        # the J(sigma) table likewise
        sl._tables.cache_clear()
        J1 = sl._tables(2)[1]
        assert len(list((tmp_path / "stagnation_J").glob("*.npy"))) == 1
        sl._tables.cache_clear()
        J2 = sl._tables(2)[1]
        eta, f, _ = solved
        J0 = sl._J_table(eta, f, float(eta[-1] - f[-1]), np.logspace(-4, 4, 801))
        assert np.array_equal(J1, J0) and np.array_equal(J2, J0)
    finally:
        sl.stagnation_profile.cache_clear()
        sl._tables.cache_clear()


def test_steady_nusselt_trapezoid_equals_scipy():
    """steady_nusselt's cumulative trapezoid (numpy, without importing scipy.integrate)
    is scipy.integrate.cumulative_trapezoid bit for bit."""
    from scipy.integrate import cumulative_trapezoid

    eta, f, _ = sl.stagnation_profile(2)
    ours = np.concatenate([[0.0], np.cumsum(np.diff(eta) * (f[1:] + f[:-1]) / 2.0)])
    assert np.array_equal(ours, cumulative_trapezoid(f, eta, initial=0.0))
    # Homann, Pr = 1: Nu / sqrt(Re) = 0.763 (Sibulkin 1952, axisymmetric stagnation point)
    assert abs(sl.steady_nusselt(1.0, 2) - 0.763) < 2e-3
