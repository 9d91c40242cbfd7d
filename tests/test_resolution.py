"""sphfem.resolution.scaled_resolution: every resolution length scales, nothing else."""

import pytest

from sphfem.resolution import scaled_resolution
from sphfem.scene import load_scene, parse_scene

SCENE = "examples/droplet_impact/droplet_impact.toml"


def test_scales_dx_gap_and_mesh_sizes_only():
    sc = load_scene(SCENE)
    d0 = sc.to_dict()
    d = scaled_resolution(sc, 0.5)
    assert d["sph"]["dx"] == pytest.approx(0.5 * d0["sph"]["dx"])
    drop0 = next(b for b in d0["blocks"] if b["name"] == "droplet")
    drop = next(b for b in d["blocks"] if b["name"] == "droplet")
    assert drop["gap"] == pytest.approx(0.5 * drop0["gap"])
    assert drop["radius"] == drop0["radius"]          # geometry is not a resolution length
    m0, m = d0["coupling"]["mesh"], d["coupling"]["mesh"]
    assert m["h_fine"] == pytest.approx(0.5 * m0["h_fine"])
    assert m["h_coarse"] == pytest.approx(0.5 * m0["h_coarse"])
    assert m["refine_radius"] == m0["refine_radius"]
    assert d["time"] == d0["time"]
    parse_scene(d)  # still a valid scene (the gap stays >= R)


def test_bad_factor():
    with pytest.raises(ValueError, match="factor must be > 0"):
        scaled_resolution(load_scene(SCENE), 0.0)
