"""HeatParams is derived from the ``[heat]`` declaration (as FluidParams from ``[fluid]``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from sphfem.heat.params import RUN_FIELDS, HeatParams, params_from_scene
from sphfem.heat.scene_section import HEAT
from sphfem.schema import Param, Section
from sphfem.schema.params import section_dataclass

SCENE = Path(__file__).resolve().parents[1] / "examples" / "heat_rod" / "heat_rod.toml"


def test_heat_params_have_every_declared_key_with_its_default():
    pa = HeatParams()
    for p in HEAT.params:
        assert getattr(pa, p.name) == p.default, p.name
    assert set(RUN_FIELDS) <= set(vars(pa))
    assert pa.boundaries == [] and pa.materials == {} and pa.initial_temperature is None
    assert HeatParams().boundaries is not pa.boundaries  # a fresh list per object


def test_heat_params_check_the_declared_bounds_and_choices():
    with pytest.raises(ValueError, match="theta"):  # declared in [0.5, 1]
        HeatParams(theta=0.2)
    with pytest.raises(ValueError, match="cfl"):  # declared in (0, 1]
        HeatParams(cfl=1.5)
    with pytest.raises(ValueError, match="free_surface_plain"):  # declared in (0, 1]
        HeatParams(free_surface_plain=0.0)
    with pytest.raises(ValueError, match="unknown heat laplacian"):
        HeatParams(laplacian="brookshaw")
    with pytest.raises(ValueError, match="eta_place < eta_trim"):
        HeatParams(eta_place=1.4, eta_trim=1.3)


def test_a_key_added_to_a_declaration_becomes_a_field():
    """The dataclass follows the section: a new key needs no edit of the parameters."""
    extra = Section("heat", HEAT.params + (Param("new_key", float, 2.5, positive=True),))
    cls = section_dataclass("P", extra, RUN_FIELDS, module=__name__, doc="test")
    assert cls().new_key == 2.5 and cls(new_key=3.0).new_key == 3.0
    assert "new_key" in cls.__doc__


def test_params_from_scene_takes_every_key_of_the_section():
    from sphfem.scene import load_scene

    scene = load_scene(SCENE)
    pa = params_from_scene(scene)
    for p in HEAT.params:
        assert getattr(pa, p.name) == scene.heat[p.name], p.name
    assert (pa.laplacian, pa.theta, pa.implicit_dt_factor) == ("fatehi_manzari", 0.5, 10.0)
    assert len(pa.boundaries) == 1 and set(pa.boundaries[0].faces) == {"xmin", "xmax"}
    assert pa.materials[0].c == 1.0 and pa.materials[0].k == 1.0
