"""Memory of the main job (issue 14): set-up steps whose work arrays grew with the product
of two sizes are done in bounded blocks, with the same results."""

import tracemalloc

import numpy as np
import pytest
from skfem import MeshTet1

import sphfem.fem.substrate as fs
from sphfem.fem.substrate import FEMSubstrate


@pytest.fixture(scope="module")
def cube():
    m = MeshTet1.init_tensor(*(np.linspace(0.0, 1.0, 9),) * 3)  # 3,072 tetrahedra
    m = m.with_boundaries({"bottom": lambda x: x[2] == 0.0})
    return FEMSubstrate(m, E=1.0, nu=0.3, alpha=0.0, clamps=["bottom"])


def test_point_location_in_bounded_memory(cube, monkeypatch):
    """Locating n points used to map every point into every candidate element at once
    (3 x candidates x n doubles: 2.8 GB for the droplet job's 19,200 sensors); in blocks
    the peak stays near the block size, and the elements are scikit-fem's."""
    X = np.random.default_rng(3).uniform(0.0, 1.0, size=(3, 3000))
    ref = cube.mesh.element_finder(mapping=cube.basis.mapping)(*X)
    monkeypatch.setattr(fs, "_FIND_BLOCK", 1 << 16)
    tracemalloc.start()
    try:
        cells, _ = cube._locate(X)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(cells, ref)
    # per entry of a block: the shifted points and reference coordinates (3 + 3 doubles),
    # two doubles and a few bytes of temporaries (~70 B); plus O(n) arrays (the k-nearest
    # query); the unblocked search needs ~3,000 x 3,000 x 3 doubles here (216 MB)
    assert peak < 80 * (1 << 16) + 500 * X.shape[1], peak
    with pytest.raises(ValueError, match="outside the mesh"):
        cube._locate(np.array([[0.5], [0.5], [1.5]]))
