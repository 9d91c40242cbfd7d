"""Shared small kernels (sphfem.smallmat): pair separation against numpy's minimum image,
the three inverses against numpy.linalg.inv, the renormalisation fallback, and that the
fluid passes / operators use these single implementations."""

import pathlib
import re

import numpy as np
import pytest
from numba import njit

import sphfem
from sphfem import kernels, operators, smallmat
from sphfem.fluid import passes


@njit(cache=False)
def _pairs_vector(x, period):
    n, dim = x.shape
    out = np.empty((n, n, dim))
    d = np.empty((n, n))
    r = np.empty(dim)
    for i in range(n):
        for j in range(n):
            d[i, j] = smallmat.pair_vector(x, i, j, period, r)
            out[i, j] = r
    return out, d


@njit(cache=False)
def _pairs_sep(x, period, periodic):
    n, dim = x.shape
    out = np.zeros((n, n, 3))
    for i in range(n):
        for j in range(n):
            r0, r1, r2 = smallmat.pair_sep(x, i, j, dim, period, periodic)
            out[i, j, 0] = r0
            out[i, j, 1] = r1
            out[i, j, 2] = r2
    return out


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_pair_separation_is_minimum_image(dim):
    rng = np.random.default_rng(dim)
    x = rng.random((7, dim))
    period = np.array([1.0, 0.0, 1.0][:dim])  # periodic, open, periodic
    ref = x[None, :, :] - x[:, None, :]
    for k in range(dim):
        if period[k] > 0:
            ref[..., k] -= period[k] * np.floor(ref[..., k] / period[k] + 0.5)
    r, d = _pairs_vector(x, period)
    np.testing.assert_allclose(r, ref, rtol=0, atol=1e-15)
    np.testing.assert_allclose(d, np.linalg.norm(ref, axis=-1), rtol=1e-15, atol=1e-15)
    s = _pairs_sep(x, period, True)
    np.testing.assert_array_equal(s[..., :dim], r)
    assert np.all(s[..., dim:] == 0.0)


@njit(cache=False)
def _inv3(M, cond_max):
    B = np.zeros_like(M)
    good = smallmat.invert3(M, M.shape[0], B, cond_max)
    return good, B


@njit(cache=False)
def _inv_sym3(M, cond_max):
    p = np.zeros((3, 3))
    p[: M.shape[0], : M.shape[0]] = M
    res = smallmat.invert_sym3(p[0, 0], p[0, 1], p[0, 2], p[1, 1], p[1, 2], p[2, 2],
                               M.shape[0], cond_max)
    B = np.array(res[1:]).reshape(3, 3)[: M.shape[0], : M.shape[0]].copy()
    return res[0], B


@pytest.mark.parametrize("n", [1, 2, 3])
def test_inverses_agree_with_numpy(n):
    rng = np.random.default_rng(10 + n)
    A = rng.random((n, n)) + n * np.eye(n)
    S = A + A.T
    inv = np.linalg.inv
    Ainv = np.empty((n, n))
    cond = smallmat.invert_small(A, Ainv)
    np.testing.assert_allclose(Ainv, inv(A), rtol=1e-12, atol=1e-14)
    expected = np.abs(A).sum(axis=0).max() * np.abs(inv(A)).sum(axis=0).max()
    assert cond == pytest.approx(expected, rel=1e-12)
    good, B = _inv3(A, 1e8)
    assert good
    np.testing.assert_allclose(B, inv(A), rtol=1e-12, atol=1e-14)
    good, B = _inv_sym3(S, 1e8)
    assert good
    np.testing.assert_allclose(B, inv(S), rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("n", [2, 3])
def test_inverses_reject_singular_and_ill_conditioned(n):
    A = np.ones((n, n))  # rank one
    assert smallmat.invert_small(A, np.empty((n, n))) == np.inf
    assert not _inv3(A, 1e8)[0]
    assert not _inv_sym3(A, 1e8)[0]
    D = np.diag([1.0] + [1e-6] * (n - 1))  # cond_1 = 1e6
    assert _inv3(D, 1e8)[0] and not _inv3(D, 1e5)[0]
    assert _inv_sym3(D, 1e8)[0] and not _inv_sym3(D, 1e5)[0]


@njit(cache=False)
def _renorm(Ms, cond_max):
    n, dim = Ms.shape[0], Ms.shape[1]
    B = np.zeros((n, dim, dim))
    ok = np.zeros(n, dtype=np.bool_)
    Bi = np.empty((dim, dim))
    for i in range(n):
        smallmat.store_renormalisation(Ms[i], Bi, cond_max, B, ok, i)
    return B, ok


def test_renormalisation_falls_back_to_identity():
    good = np.array([[2.0, 0.5], [0.5, 1.0]])
    Ms = np.stack([good, np.zeros((2, 2)), np.diag([1.0, 1e-10])])
    B, ok = _renorm(Ms, 1e8)
    assert ok.tolist() == [True, False, False]
    np.testing.assert_allclose(B[0], np.linalg.inv(good), rtol=1e-14)
    np.testing.assert_array_equal(B[1], np.eye(2))
    np.testing.assert_array_equal(B[2], np.eye(2))


def test_one_implementation_each():
    """FASTMATH is defined once (sphfem.kernels); the fluid passes, the operators and the
    TL-SPH reference configuration use the shared kernels, not copies (the fluid modules
    import sphfem.smallmat; passes.py re-exports no private aliases)."""
    root = pathlib.Path(sphfem.__file__).parent
    defs = [p.relative_to(root).as_posix() for p in root.rglob("*.py")
            if re.search(r"^FASTMATH\s*=\s*\{", p.read_text(), re.M)]
    assert defs == ["kernels.py"]
    assert operators.FASTMATH is kernels.FASTMATH and passes.FASTMATH is kernels.FASTMATH
    assert passes.pair_sep is smallmat.pair_sep  # the fluid passes use the shared helpers
    assert passes.invert_sym3 is smallmat.invert_sym3
    for name in ("_sep", "_invert", "_invert_sym"):  # and re-export no private aliases
        assert not hasattr(passes, name), name
    for p in (root / "fluid").glob("*.py"):  # no copy of a small-matrix helper in the fluid
        assert not re.search(r"^def (_sep|_invert|_invert_sym|pair_sep|invert3)\(",
                             p.read_text(), re.M), p.name
    assert operators.invert_small is smallmat.invert_small
    for name in ("_pair", "_psep"):
        src = (root / "operators.py").read_text() + (root / "fluid/passes.py").read_text()
        assert f"def {name}(" not in src
    assert "invert_small(" not in (root / "solid/reference.py").read_text()
