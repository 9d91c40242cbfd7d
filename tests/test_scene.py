"""Scene files: valid scenes parse; each mistake gives a one-line SceneError naming the key."""

from __future__ import annotations

import copy
import json
import pickle
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from sphfem import schema
from sphfem.scene import Scene, SceneError, load_scene, parse_scene, parse_scene_toml
from sphfem.schema import Param, Section

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples" / "scenes").glob("*.toml"))

BASE = """
[scene]
name = "base"
dim = 2
seed = 3

[domain]
lo = [0.0, 0.0]
hi = [1.0, 1.0]

[sph]
dx = 0.05

[materials.water]
rho0 = 1000.0
nu = 0.3

[materials.steel]
rho0 = 7850.0

[[blocks]]
name = "floor"
shape = "box"
kind = "wall"
material = "steel"
lo = [0.0, 0.0]
hi = [1.0, 0.1]

[[blocks]]
name = "drop"
shape = "sphere"
kind = "fluid"
material = "water"
center = [0.5, 0.5]
radius = 0.2
velocity = [0.0, -1.0]
temperature = "80 C"

[physics]
modules = []

[time]
t_end = 0.1

[output]
every = 0.01
"""


def base() -> dict:
    return tomllib.loads(BASE)


DELETE = object()


def mutate(data: dict, path: str, value) -> dict:
    """Copy of ``data`` with the key at dotted ``path`` (ints index arrays) set or deleted."""
    data = copy.deepcopy(data)
    *head, last = [int(p) if p.isdigit() else p for p in path.split(".")]
    node = data
    for p in head:
        node = node[p]
    if value is DELETE:
        del node[last]
    else:
        node[last] = value
    return data


@pytest.fixture
def demo_module():
    """A physics module '_demo' with its own section, removed again after the test."""
    sec = Section("_demo", (
        Param("laplacian", str, "cleary", choices=("cleary", "fatehi_manzari"),
              doc="Laplacian operator"),
        Param("theta", float, 0.5, ge=0.0, le=1.0, doc="implicitness"),
    ), doc="test module")
    schema.register_module("_demo", sec)
    yield sec
    schema.unregister("_demo")


# -- valid scenes ----------------------------------------------------------------------


def test_base_scene_parses_with_defaults():
    s = parse_scene(base(), source="scene.toml")
    assert isinstance(s, Scene)
    assert s.name == "base" and s.dim == 2 and s.seed == 3
    assert s.sph.kernel == "wendland_c2" and s.sph.support_factor == 3.0
    assert s.support_radius == pytest.approx(0.15)
    assert s.domain.periodic == (False, False)
    assert s.materials["water"].rho0 == 1000.0 and s.materials["water"].k is None
    assert s.material_names == ("water", "steel") and s.material_index("steel") == 1
    floor, drop = s.blocks
    assert floor.shape == "box" and floor.lo == (0.0, 0.0) and "radius" not in floor
    assert drop.radius == 0.2 and drop.velocity == (0.0, -1.0)
    assert drop.temperature == pytest.approx(353.15) and floor.temperature == 293.15
    assert drop.sampling == "lattice" and drop.dx is None
    assert s.physics.modules == ()
    assert s.time.dt is None and s.time.cfl == 0.25 and s.time.max_steps is None
    assert s.output.format == "vtu" and s.output.fields is None


def test_default_name_and_block_names(tmp_path):
    d = mutate(base(), "scene.name", DELETE)
    d = mutate(d, "blocks.0.name", DELETE)
    f = tmp_path / "my_run.toml"
    f.write_text(BASE.replace('name = "base"\n', "").replace('name = "floor"\n', ""))
    s = load_scene(f)
    assert s.name == "my_run" and s.blocks[0].name == "block0" and s.source == str(f)
    assert parse_scene(d).name == "scene"


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_examples_parse(path):
    s = load_scene(path)
    json.dumps(s.to_dict())
    assert s.blocks


def test_to_dict_round_trip_and_json():
    s = parse_scene(base())
    d = s.to_dict()
    json.dumps(d)
    assert d["blocks"][1]["temperature"] == pytest.approx(353.15)
    assert parse_scene(d) == s
    assert parse_scene(json.loads(json.dumps(d))) == s


def test_scene_is_read_only_and_picklable():
    s = parse_scene(base())
    with pytest.raises(AttributeError):
        s.sph.dx = 1.0
    with pytest.raises(TypeError):
        s.materials["x"] = None
    with pytest.raises(AttributeError):
        s.dim = 3
    assert pickle.loads(pickle.dumps(s)) == s
    assert s.sph.replace(dx=0.1).dx == 0.1


@pytest.mark.parametrize("text,kelvin", [
    (300, 300.0), (300.5, 300.5), ("100 C", 373.15), ("100 degC", 373.15),
    ("100 °C", 373.15), ("373.15 K", 373.15), ("-20C", 253.15), ("1e2 C", 373.15),
])
def test_temperature_units(text, kelvin):
    s = parse_scene(mutate(base(), "blocks.1.temperature", text))
    assert s.blocks[1].temperature == pytest.approx(kelvin)


def test_module_section_defaults_and_values(demo_module):
    d = mutate(base(), "physics.modules", ["_demo"])
    s = parse_scene(d)
    assert s._demo.laplacian == "cleary" and s._demo.theta == 0.5
    d["_demo"] = {"laplacian": "fatehi_manzari"}
    s = parse_scene(d)
    assert s._demo.laplacian == "fatehi_manzari"
    assert s.to_dict()["_demo"] == {"laplacian": "fatehi_manzari", "theta": 0.5}
    assert parse_scene(s.to_dict()) == s
    assert parse_scene(base())._demo is None  # registered but not used


def test_module_registration_is_idempotent(demo_module):
    schema.register_module("_demo", demo_module)  # same declaration: fine
    with pytest.raises(ValueError):
        schema.register_module("_demo", Section("_demo", (Param("x", float, 1.0),)))


def test_nested_subsections():
    sec = Section("_nest", (Param("method", str, "artificial",
                                  choices=("artificial", "laminar")),),
                  subsections=(Section("artificial", (Param("alpha", float, 0.1, ge=0),)),))
    schema.register_module("_nest", sec)
    try:
        d = mutate(base(), "physics.modules", ["_nest"])
        assert parse_scene(d)._nest.artificial.alpha == 0.1
        d["_nest"] = {"artificial": {"alpha": -1}}
        with pytest.raises(SceneError) as e:
            parse_scene(d)
        assert e.value.key == "_nest.artificial.alpha"
        d["_nest"] = {"artificial": {"alpah": 1}}
        with pytest.raises(SceneError, match="did you mean 'alpha'"):
            parse_scene(d)
    finally:
        schema.unregister("_nest")


# -- malformed scenes -------------------------------------------------------------------

MALFORMED = [
    # (id, path, value, expected key, expected text)
    ("unknown-section", "sphh", {"dx": 0.1}, "sphh", "did you mean 'sph'"),
    ("unknown-key", "sph.dxx", 0.1, "sph.dxx", "did you mean 'dx'"),
    ("wrong-type", "sph.dx", "0.1", "sph.dx", "expected a positive spacing in m"),
    ("missing-required", "sph.dx", DELETE, "sph.dx", "missing required key"),
    ("negative-spacing", "sph.dx", -0.1, "sph.dx", "got -0.1"),
    ("support-factor", "sph.support_factor", 1.0, "sph.support_factor", "> 1"),
    ("kernel-choice", "sph.kernel", "wendland", "sph.kernel", "did you mean 'wendland_c2'"),
    ("vector-length", "domain.lo", [0.0, 0.0, 0.0], "domain.lo", "dim = 2"),
    ("domain-hi-lo", "domain.hi", [1.0, 0.0], "domain.hi", "must exceed domain.lo"),
    ("periodic-length", "domain.periodic", [True], "domain.periodic", "one per axis"),
    ("periodic-type", "domain.periodic", [1, 0], "domain.periodic", "booleans"),
    ("unknown-material", "blocks.1.material", "watr", "blocks[1].material",
     "did you mean 'water'"),
    ("kind-ghost", "blocks.0.kind", "ghost", "blocks[0].kind", '"fluid", "wall", "solid"'),
    ("bad-shape", "blocks.0.shape", "cube", "blocks[0].shape", "one of"),
    ("key-not-for-shape", "blocks.0.radius", 0.1, "blocks[0].radius", "does not apply"),
    ("missing-shape-key", "blocks.1.radius", DELETE, "blocks[1].radius",
     'needed when shape = "sphere"'),
    ("outside-domain", "blocks.1.center", [0.5, 0.9], "blocks[1]", "outside the domain"),
    ("box-hi-lo", "blocks.0.hi", [1.0, 0.0], "blocks[0].hi", "must exceed"),
    ("cylinder-axis-2d", "blocks.1", {"shape": "cylinder", "kind": "fluid",
                                      "material": "water", "center": [0.5, 0.5],
                                      "radius": 0.1, "length": 0.2, "axis": "z"},
     "blocks[1].axis", "does not exist in 2D"),
    ("block-dx", "blocks.1.dx", 0.0, "blocks[1].dx", "positive spacing"),
    ("sampling", "blocks.1.sampling", "random", "blocks[1].sampling", "one of"),
    ("velocity-length", "blocks.1.velocity", [1.0], "blocks[1].velocity", "dim = 2"),
    ("temperature-text", "blocks.1.temperature", "hot", "blocks[1].temperature",
     "temperature"),
    ("temperature-below-0K", "blocks.1.temperature", "-300 C", "blocks[1].temperature",
     "above 0 K"),
    ("duplicate-block-name", "blocks.1.name", "floor", "blocks[1].name", "already used"),
    ("no-blocks", "blocks", DELETE, "blocks", "at least 1"),
    ("blocks-not-array", "blocks", {"shape": "box"}, "blocks", "array of tables"),
    ("rho0-zero", "materials.water.rho0", 0.0, "materials.water.rho0",
     "positive density in kg/m^3"),
    ("nu-range", "materials.water.nu", 0.5, "materials.water.nu", "in (-1, 0.5)"),
    ("material-unknown-key", "materials.water.rho", 1.0, "materials.water.rho",
     "did you mean 'rho0'"),
    ("material-not-table", "materials.water", 1000.0, "materials.water", "expected a table"),
    ("unregistered-module", "physics.modules", ["heat_xyz"], "physics.modules[0]",
     "unknown physics module"),
    ("modules-type", "physics.modules", "heat", "physics.modules", "list of strings"),
    ("t_end-zero", "time.t_end", 0, "time.t_end", "positive time in s"),
    ("no-time", "time", DELETE, "time", "missing required section"),
    ("dt-above-t_end", "time.dt", 1.0, "time.dt", "exceeds t_end"),
    ("cfl-range", "time.cfl", 1.5, "time.cfl", "in (0, 1]"),
    ("max-steps-int", "time.max_steps", 1.5, "time.max_steps", "integer"),
    ("dim", "scene.dim", 4, "scene.dim", "one of 1, 2, 3"),
    ("dim-bool", "scene.dim", True, "scene.dim", "one of"),
    ("seed-negative", "scene.seed", -1, "scene.seed", "non-negative integer"),
    ("output-format", "output.format", "vtk", "output.format", '"vtu"'),
    ("output-every", "output.every", -1.0, "output.every", "positive interval in s"),
    ("section-not-table", "sph", 0.1, "sph", "expected a table"),
    ("huge-count", "sph.dx", 1e-9, "sph.dx", "particles"),
    ("huge-int", "sph.dx", 10**400, "sph.dx", "expected"),
]


@pytest.mark.parametrize("case", MALFORMED, ids=[c[0] for c in MALFORMED])
def test_malformed_scene(case):
    _, path, value, key, text = case
    with pytest.raises(SceneError) as e:
        parse_scene(mutate(base(), path, value), source="scene.toml")
    msg = str(e.value)
    assert "\n" not in msg
    assert e.value.key == key
    assert msg.startswith(f"scene.toml: {key}: ")
    assert text in msg, msg


def test_exact_message_format():
    with pytest.raises(SceneError) as e:
        parse_scene(mutate(base(), "blocks.1.radius", -0.1), source="scene.toml")
    assert str(e.value) == "scene.toml: blocks[1].radius: expected a positive length in m, got -0.1"


def test_module_section_without_module(demo_module):
    d = base()
    d["_demo"] = {"laplacian": "cleary"}
    with pytest.raises(SceneError) as e:
        parse_scene(d, source="s.toml")
    assert e.value.key == "_demo" and "not listed in physics.modules" in str(e.value)


def test_module_errors(demo_module):
    d = mutate(base(), "physics.modules", ["_demo", "_demo"])
    with pytest.raises(SceneError, match=r"physics.modules\[1\]: .*listed twice"):
        parse_scene(d)
    d = mutate(base(), "physics.modules", ["_dmo"])
    with pytest.raises(SceneError, match="did you mean '_demo'"):
        parse_scene(d)
    d = mutate(base(), "physics.modules", ["_demo"])
    d["_demo"] = {"laplacian": "fatehi"}
    with pytest.raises(SceneError) as e:
        parse_scene(d)
    assert e.value.key == "_demo.laplacian" and "fatehi_manzari" in str(e.value)


def test_toml_syntax_error_names_line(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text("[scene]\ndim = 2\nname = \n")
    with pytest.raises(SceneError) as e:
        load_scene(f)
    assert e.value.key == "line 3" and "invalid TOML" in str(e.value)
    assert str(e.value).startswith(f"{f}: line 3: ")
    assert "\n" not in str(e.value)


def test_missing_file(tmp_path):
    with pytest.raises(SceneError, match="cannot read scene file"):
        load_scene(tmp_path / "nope.toml")


def test_overlapping_blocks_named():
    from sphfem.geometry import build_particles

    d = mutate(base(), "blocks.1.center", [0.5, 0.25])
    s = parse_scene(d, source="scene.toml")
    with pytest.raises(SceneError) as e:
        build_particles(s)
    assert e.value.key == "blocks[1]"
    assert "'drop' overlaps block 'floor'" in str(e.value)


# -- property tests ---------------------------------------------------------------------

_bad_type = st.one_of(st.text(max_size=5), st.booleans(), st.lists(st.integers(), max_size=2),
                      st.dictionaries(st.text(max_size=3), st.integers(), max_size=2))
_nonpos = st.one_of(st.floats(max_value=0.0), st.integers(max_value=0), st.just(float("nan")),
                    st.just(float("inf")), _bad_type)


def _not_in(choices):
    return st.one_of(st.text(max_size=12).filter(lambda t: t not in choices), st.integers(),
                     st.floats(allow_nan=False), st.booleans())


def _wrong_vector(n):
    good = st.floats(-1e3, 1e3)
    return st.one_of(
        st.lists(good, max_size=4).filter(lambda v: len(v) != n),
        st.lists(st.one_of(st.text(max_size=3), st.booleans()), min_size=n, max_size=n),
        _bad_type.filter(lambda v: not isinstance(v, list)), st.floats(),
    )


BAD_VALUES = {
    "sph.dx": _nonpos,
    "sph.support_factor": st.one_of(st.floats(max_value=1.0), _bad_type),
    "sph.kernel": _not_in(("wendland_c2", "cubic_spline")),
    "domain.lo": _wrong_vector(2),
    "domain.periodic": st.one_of(st.lists(st.booleans(), max_size=4).filter(lambda v: len(v) != 2),
                                 st.lists(st.integers(), min_size=2, max_size=2)),
    "scene.seed": st.one_of(st.integers(max_value=-1), st.text(max_size=3)),
    "scene.dim": st.one_of(st.integers().filter(lambda i: i not in (1, 2, 3)), _bad_type),
    "time.t_end": _nonpos,
    "time.cfl": st.one_of(st.floats(max_value=0.0), st.floats(min_value=1.0, exclude_min=True),
                          _bad_type),
    "materials.water.rho0": _nonpos,
    "materials.water.nu": st.one_of(st.floats(max_value=-1.0), st.floats(min_value=0.5),
                                    _bad_type),
    "materials.steel.E": _nonpos,
    "blocks.1.radius": _nonpos,
    "blocks.1.kind": _not_in(("fluid", "wall", "solid")),
    "blocks.1.velocity": _wrong_vector(2),
    "blocks.1.temperature": st.one_of(st.floats(max_value=0.0), st.text(max_size=4)
                                      .filter(lambda t: not t.strip().endswith(("K", "C")))),
    "blocks.0.lo": _wrong_vector(2),
    "output.every": _nonpos,
    "output.fields": st.one_of(st.text(max_size=3), st.lists(st.integers(), min_size=1)),
}


def _key_of(path: str) -> str:
    parts = path.split(".")
    return ".".join(f"[{p}]" if p.isdigit() else p for p in parts).replace(".[", "[")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), path=st.sampled_from(sorted(BAD_VALUES)))
def test_property_bad_value_names_key(data, path):
    value = data.draw(BAD_VALUES[path])
    with pytest.raises(SceneError) as e:
        parse_scene(mutate(base(), path, value), source="p.toml")
    key = _key_of(path)
    assert e.value.key == key
    assert f": {key}: " in str(e.value) and "\n" not in str(e.value)


_ident = st.from_regex(r"[a-z_][a-z0-9_]{0,10}", fullmatch=True)


@settings(max_examples=100, deadline=None)
@given(section=st.sampled_from(["scene", "domain", "sph", "time", "output", "physics",
                                "materials.water", "blocks.0"]), name=_ident)
def test_property_unknown_key_named(section, name):
    d = base()
    node = d
    for p in section.split("."):
        node = node[int(p)] if p.isdigit() else node[p]
    assume(name not in node and name not in schema.SECTIONS["blocks"].keys
           and name not in schema.SECTIONS[section.split(".")[0]].keys)
    node[name] = 1
    with pytest.raises(SceneError) as e:
        parse_scene(d)
    assert e.value.key == _key_of(f"{section}.{name}")


_json = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=6)),
    lambda inner: st.one_of(st.lists(inner, max_size=3),
                            st.dictionaries(st.text(max_size=6), inner, max_size=3)),
    max_leaves=8,
)


def _paths(node, prefix=""):
    out = [prefix] if prefix else []
    items = (node.items() if isinstance(node, dict) else
             enumerate(node) if isinstance(node, list) else [])
    for k, v in items:
        out += _paths(v, f"{prefix}.{k}" if prefix else str(k))
    return out


_ALL_PATHS = _paths(base())


@settings(max_examples=300, deadline=None)
@given(path=st.sampled_from(_ALL_PATHS), value=_json)
def test_property_garbage_never_crashes(path, value):
    """Any value anywhere: the scene parses or raises SceneError, never another exception."""
    try:
        parse_scene(mutate(base(), path, value))
    except SceneError as e:
        assert "\n" not in str(e) and e.key is not None


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=60))
def test_property_random_toml_text(text):
    try:
        parse_scene_toml(BASE + "\n" + text)
    except SceneError as e:
        assert "\n" not in str(e)


# -- docs -------------------------------------------------------------------------------


def test_docs_are_generated_from_schema():
    """docs/scenes.md must equal the generated reference: run `python -m sphfem.schema`."""
    expected = schema.describe_markdown()
    actual = schema.docs_path().read_text(encoding="utf-8")
    assert actual == expected, "docs/scenes.md is stale: regenerate with `python -m sphfem.schema`"


def test_docs_mention_every_key():
    text = schema.describe_markdown()
    for sec in schema.all_sections().values():
        for p in sec.params:
            assert f"`{p.name}`" in text


def test_custom_param_and_repeated_subsection():
    def face(v, ctx, key):
        if v in ("insulated", "free"):
            return v
        if isinstance(v, list) and len(v) == 2 and v[0] == "dirichlet":
            return ("dirichlet", schema.convert(Param("T", schema.TEMPERATURE), v[1], ctx, key))
        ctx.error(key, f'expected "insulated", "free" or ["dirichlet", T], got {v!r}')

    bnd = Section("boundaries", (Param("xmin", schema.CUSTOM, "insulated", convert=face,
                                       type_doc="face condition"),), repeated=True)
    schema.register_module("_bc", Section("_bc", (), subsections=(bnd,)))
    try:
        d = mutate(base(), "physics.modules", ["_bc"])
        d["_bc"] = {"boundaries": [{"xmin": ["dirichlet", "100 C"]}, {}]}
        s = parse_scene(d)
        assert s._bc.boundaries[0].xmin == ("dirichlet", pytest.approx(373.15))
        assert s._bc.boundaries[1].xmin == "insulated"
        assert parse_scene(s.to_dict()) == s
        d["_bc"] = {"boundaries": [{}, {"xmin": "hot"}]}
        with pytest.raises(SceneError) as e:
            parse_scene(d)
        assert e.value.key == "_bc.boundaries[1].xmin"
        assert "face condition" in schema.describe_markdown()
    finally:
        schema.unregister("_bc")


def test_module_check_sees_core_sections():
    def check(rec, ctx, path):
        names = [b.name for b in ctx.core["blocks"]]
        if rec.block not in names:
            ctx.error(f"{path}.block", f"no block named {rec.block!r}")

    schema.register_module("_ref", Section("_ref", (Param("block", str, "floor"),),
                                           check=check))
    try:
        d = mutate(base(), "physics.modules", ["_ref"])
        assert parse_scene(d)._ref.block == "floor"
        d["_ref"] = {"block": "nope"}
        with pytest.raises(SceneError, match=r"_ref.block: no block named 'nope'"):
            parse_scene(d)
    finally:
        schema.unregister("_ref")
