"""The Poisson-disk sample cache: a cached sample is the one the sampler gives, and a second
call with equal parameters does not run the sampler (sphfem.cache, sphfem.geometry)."""

import numpy as np
import pytest

from sphfem import geometry
from sphfem.geometry import Shape, poisson_points


def test_cached_sample_equals_the_sampler_and_is_reused(tmp_path, monkeypatch):
    monkeypatch.setenv("SPHFEM_CACHE", str(tmp_path))
    disc = Shape.sphere([0.0, 0.0], 0.5)
    first = poisson_points(disc, 0.05, 2, seed=[3, 1])
    direct = geometry._poisson_points(disc, 0.05, [3, 1], 3, 0.03)
    assert np.array_equal(first, direct)
    assert len(list((tmp_path / "poisson").glob("*.npy"))) == 1

    def no_sampling(*a, **k):
        raise AssertionError("the sampler ran although the sample is cached")

    monkeypatch.setattr(geometry, "_poisson_box", no_sampling)
    again = poisson_points(disc, 0.05, 2, seed=[3, 1])
    assert np.array_equal(again, first)
    # another seed or spacing is another sample: the sampler must run
    with pytest.raises(AssertionError, match="sampler ran"):
        poisson_points(disc, 0.05, 2, seed=[3, 2])
    with pytest.raises(AssertionError, match="sampler ran"):
        poisson_points(disc, 0.04, 2, seed=[3, 1])


def test_unwritable_cache_only_costs_the_recomputation(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("SPHFEM_CACHE", str(blocker))
    box = Shape.box([0.0, 0.0], [1.0, 0.5])
    x = poisson_points(box, 0.1, 2, seed=0)
    assert np.array_equal(x, geometry._poisson_points(box, 0.1, 0, 3, 0.03))
