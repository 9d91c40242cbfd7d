"""The numba signed distance of :mod:`sphfem.fluid.no_penetration` against its k-d tree /
numpy reference (the form it replaced): the same phi and normals to the bit."""

import numpy as np
import pytest

from sphfem.fluid.no_penetration import NoPenetration


def _box_wall(s, nx, layers, dim):
    """A wall box of ``layers`` layers (spacing s, top face z = 0) with normals +e_z and a
    vertical wall of 4 columns (face at the box's far end, normal -e_r) on top of it."""
    g = (np.arange(nx) + 0.5) * s
    if dim == 2:
        pts = np.array(np.meshgrid(g, -(np.arange(layers) + 0.5) * s)).reshape(2, -1).T
        up = np.tile([0.0, 1.0], (len(pts), 1))
        side = np.array(np.meshgrid(nx * s + (np.arange(4) + 0.5) * s,
                                    (np.arange(6) + 0.5) * s)).reshape(2, -1).T
        left = np.tile([-1.0, 0.0], (len(side), 1))
    else:
        pts = np.array(np.meshgrid(g, g, -(np.arange(layers) + 0.5) * s)).reshape(3, -1).T
        up = np.tile([0.0, 0.0, 1.0], (len(pts), 1))
        side = np.array(np.meshgrid(nx * s + (np.arange(4) + 0.5) * s, g,
                                    (np.arange(6) + 0.5) * s)).reshape(3, -1).T
        left = np.tile([-1.0, 0.0, 0.0], (len(side), 1))
    xw = np.vstack([pts, side])
    nw = np.vstack([up, left])
    nw[::7] = 0.0  # walls without a normal take no part
    return xw, nw


@pytest.mark.parametrize("dim", [2, 3])
def test_distance_equals_reference(dim):
    """Random points over, inside and beside the walls (and far away): phi identical to the
    reference everywhere, normals identical where phi is finite."""
    s = 0.1
    xw, nw = _box_wall(s, 14, 3, dim)
    wall = NoPenetration(xw, nw, s**dim)
    rng = np.random.default_rng(3)
    n = 4000
    x = rng.uniform(-0.3, 14 * s + 0.8, size=(n, dim))
    x[:, -1] = rng.uniform(-0.5, 1.0, size=n)
    x[:50] = xw[rng.integers(0, len(xw), 50)]  # on wall particles (d = 0)
    x[50:60, -1] = 40.0  # far away
    phi, nrm = wall.distance(x)
    ref_phi, ref_nrm = wall.distance_reference(x)
    assert np.array_equal(phi, ref_phi)
    fin = np.isfinite(ref_phi)
    assert 0.1 * n < fin.sum() < n  # both covered and uncovered points occur
    assert (ref_phi[fin] < 0).sum() > 100
    assert np.array_equal(nrm[fin], ref_nrm[fin])
    assert np.all(nrm[~fin] == 0.0)


def test_apply_equals_reference_projection():
    """apply() moves and damps exactly as the numpy projection of the reference did."""
    s = 0.05
    xw, nw = _box_wall(s, 20, 4, 2)
    wall = NoPenetration(xw, nw, s * s)
    rng = np.random.default_rng(7)
    x = rng.uniform([0.0, -0.15], [1.3, 0.3], size=(3000, 2))
    v = rng.normal(size=(3000, 2))
    x1, v1 = x.copy(), v.copy()
    moved = wall.apply(x1, v1)
    phi, nrm = wall.distance_reference(x)
    bad = np.flatnonzero(phi < 0.0)
    x2, v2 = x.copy(), v.copy()
    x2[bad] -= phi[bad, None] * nrm[bad]
    vn = (v2[bad] * nrm[bad]).sum(axis=1)
    v2[bad] -= np.minimum(vn, 0.0)[:, None] * nrm[bad]
    assert moved == bad.size > 100
    assert np.array_equal(x1, x2) and np.array_equal(v1, v2)
