"""Kernels: unit integral by quadrature, gradient against finite differences, compact support."""

import numpy as np
import pytest
from scipy import integrate

from sphfem import kernels as K

NAMES = sorted(K.KERNELS)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_unit_integral(name, dim):
    R = 0.37
    kind = K.kernel_code(name)
    sigma = K.kernel_sigma(kind, dim, R)
    f = lambda r: K.kernel_w(r, R, sigma, kind)  # noqa: E731
    shell = {1: lambda r: 2.0, 2: lambda r: 2 * np.pi * r, 3: lambda r: 4 * np.pi * r * r}[dim]
    val, _ = integrate.quad(lambda r: shell(r) * f(r), 0.0, R, points=[0.5 * R], epsabs=1e-13)
    assert val == pytest.approx(1.0, abs=1e-10)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_gradient_matches_finite_differences(name, dim):
    R = 1.3
    rng = np.random.default_rng(3)
    dx = rng.uniform(-R / 1.5, R / 1.5, (50, dim))
    g = K.grad_w(dx, R, name)
    eps = 1e-6
    for k in range(dim):
        e = np.zeros(dim)
        e[k] = eps
        wp = K.w(np.linalg.norm(dx + e, axis=1), R, dim, name)
        wm = K.w(np.linalg.norm(dx - e, axis=1), R, dim, name)
        fd = (wp - wm) / (2 * eps)
        np.testing.assert_allclose(g[:, k], fd, rtol=1e-6, atol=1e-8 * np.abs(fd).max())


@pytest.mark.parametrize("name", NAMES)
def test_compact_support_and_shape(name):
    R = 2.0
    kind = K.kernel_code(name)
    sigma = K.kernel_sigma(kind, 3, R)
    for r in (R, R * (1 + 1e-12), 1.5 * R, 10 * R):
        assert K.kernel_w(r, R, sigma, kind) == 0.0
        assert K.kernel_dwdr(r, R, sigma, kind) == 0.0
    r = np.linspace(0, R, 401)
    w = np.array([K.kernel_w(s, R, sigma, kind) for s in r])
    d = np.array([K.kernel_dwdr(s, R, sigma, kind) for s in r])
    assert np.all(np.diff(w) <= 1e-15)  # monotone decreasing
    assert np.all(d <= 0.0) and d[0] == 0.0
    # continuity of W and dW/dr at the cubic spline's inner knot and at the support edge
    assert K.kernel_w(R * (1 - 1e-9), R, sigma, kind) < 1e-20


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_lattice_moments(name, dim):
    """Discrete zeroth and first moments on a lattice: sum V W = 1, sum V grad W = 0."""
    dx = 0.1
    R = 3 * dx
    n = 7
    ax = np.arange(-n, n + 1) * dx
    x = np.stack([a.ravel() for a in np.meshgrid(*[ax] * dim, indexing="ij")], axis=1)
    kind = K.kernel_code(name)
    sigma = K.kernel_sigma(kind, dim, R)
    r = np.linalg.norm(x, axis=1)
    m0 = dx**dim * sum(K.kernel_w(s, R, sigma, kind) for s in r)
    assert m0 == pytest.approx(1.0, rel=2e-2)
    g = K.grad_w(x, R, name)
    np.testing.assert_allclose(g.sum(axis=0), 0.0, atol=1e-10)


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown kernel"):
        K.kernel_code("gauss")
    with pytest.raises(ValueError, match="dimension"):
        K.kernel_sigma(0, 4, 1.0)
    with pytest.raises(ValueError, match="positive"):
        K.kernel_sigma(0, 2, -1.0)
