"""examples/droplet_impact/droplet_impact_reference.toml is the droplet-impact validation's
scene at 10 m/s, D/dx 181, to 4 t_c (ensemble member 0) to the last bit, so the results
committed in docs/validation/droplet_impact/reference/ are those of the file a user runs."""

from __future__ import annotations

from pathlib import Path

from sphfem.scene import load_scene, parse_scene
from sphfem.validation import droplet_impact as di

REFERENCE = Path(__file__).parents[1] / "examples" / "droplet_impact" / \
    "droplet_impact_reference.toml"


def test_reference_scene_is_the_validation_scene_at_d181():
    d = di.scene_at(10.0, 181, 4.0)
    expected = parse_scene(d, source="scene_at(10, 181, 4)").to_dict()
    ref = load_scene(REFERENCE).to_dict()
    assert ref == expected
    # and it is the packaged scene (D = 0.1 mm) with 181 particles across the droplet
    assert ref["sph"]["dx"] == 1e-4 / 181
