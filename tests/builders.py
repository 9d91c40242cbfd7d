"""Builders shared by the tests: the TOML writer of scene dicts, the periodic unit-box scene
of the driver tests, and a private mesh cache for the FEM tests.

Import them as ``from builders import ...`` (``tests/`` is on the path of the test run).
"""

from __future__ import annotations

import json
import math
import re

import pytest

# -- a small TOML writer (the scenes are built as dicts, written, and read back by sphfem) --

class Raw(str):
    """A TOML literal written as is (dates, which Python values cannot express here)."""


def _key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else _value(k)


def _value(v) -> str:
    if isinstance(v, Raw):
        return str(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else "inf" if v == math.inf else \
            "-inf" if v == -math.inf else repr(v)
    if isinstance(v, str):  # JSON escapes are TOML escapes; TOML also bars DEL
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(v)


def _is_table_array(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def _body(t: dict, path: list[str], lines: list[str]) -> None:
    for k, v in t.items():
        if not isinstance(v, dict) and not _is_table_array(v):
            lines.append(f"{_key(k)} = {_value(v)}")
    for k, v in t.items():
        if isinstance(v, dict):
            lines += ["", "[" + ".".join(map(_key, path + [k])) + "]"]
            _body(v, path + [k], lines)
        elif _is_table_array(v):
            for item in v:
                lines += ["", "[[" + ".".join(map(_key, path + [k])) + "]]"]
                _body(item, path + [k], lines)


def to_toml(d: dict) -> str:
    lines: list[str] = []
    _body(d, [], lines)
    return "\n".join(lines).lstrip("\n") + "\n"


# -- scenes ---------------------------------------------------------------------------------

#: a material of unit density, specific heat and conductivity
UNIT_MATERIAL = {"rho0": 1.0, "c": 1.0, "k": 1.0}


def solid_box(name: str = "b", lo=(0.0, 0.0), hi=(1.0, 1.0), material: str = "m",
              **keys) -> dict:
    """A ``[[blocks]]`` entry: a solid box of ``material`` (``keys``: temperature, ...)."""
    return {"name": name, "shape": "box", "kind": "solid", "material": material,
            "lo": list(lo), "hi": list(hi), **keys}


def periodic_box(modules=("heat",), *, name: str = "periodic_heat", dx: float = 0.05,
                 sph: dict | None = None, material: dict | None = None,
                 blocks: list | None = None, time: dict | None = None,
                 output: dict | None = None, **sections) -> dict:
    """The driver tests' scene: the unit square, periodic on both axes, filled by the solid
    box ``b`` of material ``m`` (unit properties unless ``material``), stepping
    ``modules`` with dt = 2e-5 s to 2e-3 s (``time``), written every 1e-3 s (``output``;
    {} for no ``[output]``).  ``sph`` adds ``[sph]`` keys to dx; ``blocks`` replaces the
    block; ``sections`` adds tables (``heat={...}``)."""
    scene = {
        "scene": {"name": name, "dim": 2},
        "domain": {"lo": [0.0, 0.0], "hi": [1.0, 1.0], "periodic": [True, True]},
        "sph": {"dx": dx, **(sph or {})},
        "materials": {"m": dict(UNIT_MATERIAL if material is None else material)},
        "blocks": [solid_box()] if blocks is None else list(blocks),
        "physics": {"modules": list(modules)},
        "time": {"t_end": 2.0e-3, "dt": 2.0e-5} if time is None else dict(time),
        **sections,
    }
    out = {"every": 1.0e-3} if output is None else output
    if out:
        scene["output"] = dict(out)
    return scene


def periodic_box_toml(modules=("heat",), **kw) -> str:
    """:func:`periodic_box` as TOML text."""
    return to_toml(periodic_box(modules, **kw))


# -- fixtures -------------------------------------------------------------------------------

@pytest.fixture(scope="module", autouse=True)
def isolated_cache(tmp_path_factory):
    """Autouse in a module that imports it: meshes and other cached artefacts go to a
    temporary ``SPHFEM_CACHE`` of the module, not the user's cache."""
    mp = pytest.MonkeyPatch()
    mp.setenv("SPHFEM_CACHE", str(tmp_path_factory.mktemp("cache")))
    yield
    mp.undo()


def load_example(path, name: str):
    """Import the example script at ``path`` as module ``name`` (examples are not a package)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def coupled_droplet_run(out, speed: float, per_diameter: int, t_end_tc: float):
    """The axisymmetric droplet job (fluid, ring heat, fem-contact substrate heat,
    fem-axisymmetric stress; ``sphfem.validation.droplet_impact.scene_at``) run into ``out``;
    returns the finished :class:`~sphfem.simulation.Simulation`."""
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation
    from sphfem.validation import droplet_impact as di

    sim = Simulation(parse_scene(di.scene_at(speed, per_diameter, t_end_tc), source="<test>"),
                     source="<test>")
    sim.run(out, progress=False)
    return sim


def as_planar_scene(d: dict) -> dict:
    """An axisymmetric scene dict (``sphfem.validation.droplet_impact.scene_at``) turned into
    the planar (x, y) scene of its (r, z) section: geometry cartesian, the domain and the
    walls mirrored to -r (in place; returned)."""
    d["scene"]["geometry"] = "cartesian"
    d["domain"]["lo"][0] = -d["domain"]["hi"][0]
    for b in d["blocks"]:
        if b["kind"] == "wall":
            b["lo"][0] = -b["hi"][0]
    return d
