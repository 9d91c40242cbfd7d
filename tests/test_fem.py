"""FEM substrate: meshing recipes, thermo-elastic patch tests, loads, probes, bad input."""

from __future__ import annotations

import importlib.util

import meshio
import numpy as np
import pytest
from builders import isolated_cache  # noqa: F401  (autouse: a private mesh cache)

from sphfem.fem import FEMSeries, FEMSubstrate, mesh_command, substrate_block, substrate_rect
from sphfem.fem.substrate import load_mesh

E, NU, ALPHA, DT = 300e9, 0.21, 7e-6, 100.0
FACES = ["left", "right", "front", "back", "bottom", "top"]
ROLLERS = {"left": "x", "right": "x", "front": "y", "back": "y", "bottom": "z"}
BOX = dict(size=(1.0, 0.8, 0.3), origin=(0.0, 0.0, 0.0), refine_center=(0.5, 0.4, 0.3),
           refine_radius=0.15)




def block(element="tet", h=0.1):
    return substrate_block(h_fine=h, h_coarse=2.5 * h, element=element, **BOX)


# ---------------------------------------------------------------- meshing
@pytest.mark.parametrize("element, cell", [("tet", "tetra"), ("hex", "hexahedron")])
def test_block_recipe_groups_and_cache(element, cell):
    p = block(element, 0.12)
    m = meshio.read(p)
    assert cell in m.cells_dict
    assert set(FACES + ["substrate"]) <= set(m.cell_sets)
    assert block(element, 0.12) == p  # cached: same parameters -> same file
    mesh = load_mesh(p)
    assert set(FACES) <= set(mesh.boundaries)
    lo, hi = mesh.p.min(axis=1), mesh.p.max(axis=1)
    assert np.allclose(lo, 0) and np.allclose(hi, BOX["size"])
    top = mesh.p[:, np.unique(mesh.facets[:, mesh.boundaries["top"]])]
    assert np.allclose(top[2], 0.3)


def test_tet_block_is_refined_under_the_centre():
    mesh = load_mesh(block("tet", 0.05))
    cen = mesh.p[:, mesh.t].mean(axis=1)
    vol = np.abs(np.linalg.det(np.moveaxis(mesh.p[:, mesh.t[1:]] - mesh.p[:, mesh.t[[0]]],
                                           (0, 1), (-1, -2)))) / 6
    near = np.linalg.norm(cen - np.array([[0.5], [0.4], [0.3]]), axis=0) < 0.1
    far = np.linalg.norm(cen - np.array([[0.5], [0.4], [0.3]]), axis=0) > 0.4
    assert np.median(vol[far]) > 5 * np.median(vol[near])


@pytest.mark.parametrize("element", ["tri", "quad"])
def test_rect_recipe(element):
    p = substrate_rect(size=(1.0, 0.3), origin=(0, 0), h_fine=0.05, h_coarse=0.1,
                       refine_radius=0.1, element=element)
    mesh = load_mesh(p)
    assert mesh.p.shape[0] == 2
    assert {"left", "right", "top", "bottom"} <= set(mesh.boundaries)


def test_mesh_command_writes_file(tmp_path, capsys):
    out = tmp_path / "b.msh"
    rc = mesh_command(["block", "--out", str(out), "--size", "1", "1", "0.5", "--h-fine", "0.2",
                       "--h-coarse", "0.4", "--refine-radius", "0.2"])
    assert rc == 0 and out.is_file()
    assert '"nodes"' in capsys.readouterr().out
    assert mesh_command(["block", "--size", "1", "1"]) == 2
    assert mesh_command(["block", "--h-fine", "0.5", "--h-coarse", "0.1"]) == 2


def test_order2_mesh_loads_as_straight_sided():
    mesh = load_mesh(substrate_block(size=(1, 1, 1), origin=(0, 0, 0), h_fine=0.5,
                                     h_coarse=0.5, order=2))
    assert type(mesh).__name__ == "MeshTet1"
    assert "top" in mesh.boundaries


# ---------------------------------------------------------------- thermo-elastic patch tests
@pytest.mark.parametrize("mesh_el, el", [("tet", "P1"), ("tet", "P2"), ("hex", "P1")])
def test_patch_tests(mesh_el, el):
    mesh = load_mesh(block(mesh_el, 0.12 if el == "P1" else 0.2))
    scale = E * ALPHA * DT
    # free block: zero stress, u = alpha dT x up to a rigid motion
    s = FEMSubstrate(mesh, E, NU, ALPHA, element=el)
    r = s.solve(dT_nodal=DT)
    assert np.abs(r.stress_elem).max() <= 1e-8 * scale
    assert np.abs(r.stress_nodes).max() <= 1e-8 * scale
    strain = np.linalg.lstsq(np.column_stack([mesh.p.T, np.ones(mesh.nvertices)]), r.u,
                             rcond=None)[0][:3]
    assert np.allclose(0.5 * (strain + strain.T), ALPHA * DT * np.eye(3), atol=1e-12)
    # clamped everywhere: hydrostatic
    s = FEMSubstrate(mesh, E, NU, ALPHA, element=el, clamps=FACES)
    r = s.solve(dT_nodal=DT)
    sig = -E * ALPHA * DT / (1 - 2 * NU)
    assert np.abs(r.stress_elem - sig * np.eye(3)).max() <= 1e-8 * abs(sig)
    # uniaxial strain
    s = FEMSubstrate(mesh, E, NU, ALPHA, element=el, rollers=ROLLERS)
    r = s.solve(dT_nodal=DT)
    sig = -E * ALPHA * DT / (1 - NU)
    assert np.abs(r.stress_nodes - np.diag([sig, sig, 0])).max() <= 1e-8 * abs(sig)
    # pressure on the rollered block: sigma_zz = -p, reaction = p A
    p = 2e6
    r = s.solve(tractions={"top": [0, 0, -p]})
    assert np.abs(r.stress_elem[:, 2, 2] + p).max() <= 1e-8 * p
    assert r.reaction("bottom")[2] == pytest.approx(p * 0.8, rel=1e-10)
    assert s.n_factorizations == 1 and s.n_solves == 2


def test_plane_strain_uniaxial():
    p = substrate_rect(size=(1.0, 0.3), origin=(0, 0), h_fine=0.05, h_coarse=0.1,
                       refine_radius=0.1, element="tri")
    s = FEMSubstrate(p, E, NU, ALPHA, element="P2",
                     rollers={"left": "x", "right": "x", "bottom": "y"})
    r = s.solve(T_nodal=s.T0 + DT)
    sig = -E * ALPHA * DT / (1 - NU)  # eps_zz = 0 too: sigma_xx = sigma_zz, sigma_yy = 0
    assert np.abs(r.stress_elem - np.diag([sig, 0, sig])).max() <= 1e-8 * abs(sig)


def test_manufactured_orders():
    from sphfem.validation.fem import mms_run

    for el, hs, order in (("P1", (0.25, 0.125), 1.6), ("P2", (0.4, 0.2), 2.5)):
        a, b = (mms_run(el, h) for h in hs)
        obs = np.log(a.error_l2 / b.error_l2) / np.log(a.resolution / b.resolution)
        assert obs > order, (el, obs)


# ---------------------------------------------------------------- loads and probes
def test_factorise_once_and_resolve():
    s = FEMSubstrate(block("tet", 0.12), E, NU, ALPHA, clamps=["bottom"])
    r1 = s.solve(dT_nodal=DT)
    r2 = s.solve(dT_nodal=2 * DT)
    s.solve(tractions={"top": [0, 0, -1e6]})
    assert s.n_factorizations == 1 and s.n_solves == 3
    assert np.allclose(r2.dofs, 2 * r1.dofs, rtol=1e-10, atol=1e-20)
    assert np.abs(r1.residual[s.I]).max() <= 1e-8 * np.abs(r1.load).max()


@pytest.mark.skipif(importlib.util.find_spec("pyamg") is None, reason="pyamg not installed")
def test_cg_amg_matches_direct():
    mesh = load_mesh(block("tet", 0.1))
    d = FEMSubstrate(mesh, E, NU, ALPHA, clamps=["bottom"])
    c = FEMSubstrate(mesh, E, NU, ALPHA, clamps=["bottom"], solver="cg-amg", rtol=1e-12)
    for k in range(2):
        rd, rc = d.solve(dT_nodal=DT * (1 + k)), c.solve(dT_nodal=DT * (1 + k))
        assert np.abs(rc.dofs - rd.dofs).max() <= 1e-8 * np.abs(rd.dofs).max()
    assert c.n_factorizations == 1 and len(c.cg_iterations) == 2


def test_point_forces_conservative_and_probes():
    s = FEMSubstrate(block("tet", 0.1), E, NU, ALPHA, element="P2", rollers=ROLLERS)
    rng = np.random.default_rng(0)
    X = np.column_stack([rng.uniform(0, 1, 50), rng.uniform(0, 0.8, 50),
                         0.3 + rng.uniform(-1e-7, 1e-7, 50)])  # some just above the top
    F = rng.normal(size=(50, 3))
    f = s.point_force_load(X, F)
    sums = [f[d].sum() for d in s.component_dofs]
    assert np.allclose(sums, F.sum(axis=0), rtol=0, atol=1e-12 * np.abs(F).sum())
    # probes of the uniaxial-strain state (u linear in z, uniform stress)
    r = s.solve(dT_nodal=DT)
    pts = np.array([[0.5, 0.4, 0.15], [0.1, 0.7, 0.29], [0.9, 0.05, 0.01]])
    out = r.probe(pts)
    ezz = (1 + NU) / (1 - NU) * ALPHA * DT
    assert np.allclose(out["u"][:, 2], ezz * pts[:, 2], rtol=1e-10)
    sig = -E * ALPHA * DT / (1 - NU)
    assert np.allclose(out["stress"], np.diag([sig, sig, 0]), atol=1e-8 * abs(sig))
    assert np.allclose(out["von_mises"], abs(sig), rtol=1e-8)
    with pytest.raises(ValueError, match="outside the mesh"):
        r.probe([[2.0, 0.0, 0.0]])


def test_traction_integral():
    s = FEMSubstrate(block("hex", 0.12), E, NU, ALPHA, clamps=["bottom"])
    f = s.traction_load({"top": lambda x: np.stack([1e5 * x[0], 0 * x[0], -1e6 * (1 + x[1])])})
    sums = np.array([f[d].sum() for d in s.component_dofs])
    exact = np.array([1e5 * 0.5 * 0.8, 0.0, -1e6 * (0.8 + 0.32)])
    assert np.allclose(sums, exact, rtol=1e-12, atol=1e-9)


def test_series_output(tmp_path):
    s = FEMSubstrate(block("tet", 0.15), E, NU, ALPHA, clamps=["bottom"])
    ser = FEMSeries(tmp_path, "sub")
    ser.write(0.0, s.solve(dT_nodal=DT))
    ser.write(1e-3, s.solve(dT_nodal=lambda x: DT * x[0]))
    pvd = (tmp_path / "sub.pvd").read_text()
    assert pvd.count("<DataSet") == 2 and "sub_00001.vtu" in pvd
    m = meshio.read(tmp_path / "sub_00001.vtu")
    assert {"displacement", "stress", "von_mises", "dT"} <= set(m.point_data)
    assert m.point_data["stress"].shape == (len(m.points), 9)
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())


# ---------------------------------------------------------------- bad input
def test_missing_mesh_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="mesh file not found"):
        FEMSubstrate(tmp_path / "nope.msh", E, NU, ALPHA)


def test_missing_group_is_named():
    mesh = load_mesh(block("tet", 0.15))
    with pytest.raises(ValueError, match=r"no boundary group 'floor'.*bottom.*top"):
        FEMSubstrate(mesh, E, NU, ALPHA, clamps=["floor"])
    s = FEMSubstrate(mesh, E, NU, ALPHA, clamps=["bottom"])
    with pytest.raises(ValueError, match="'lid'"):
        s.solve(tractions={"lid": [0, 0, 1.0]})


def test_bad_parameters():
    mesh = load_mesh(block("tet", 0.15))
    with pytest.raises(ValueError, match="element"):
        FEMSubstrate(mesh, E, NU, ALPHA, element="P3")
    with pytest.raises(ValueError, match="solver"):
        FEMSubstrate(mesh, E, NU, ALPHA, solver="magic")
    with pytest.raises(ValueError, match="nu"):
        FEMSubstrate(mesh, E, 0.5, ALPHA)
    with pytest.raises(ValueError, match="roller components"):
        FEMSubstrate(mesh, E, NU, ALPHA, rollers={"bottom": "w"})
    s = FEMSubstrate(mesh, E, NU, ALPHA, clamps=["bottom"])
    with pytest.raises(ValueError, match="dT"):
        s.solve(dT_nodal=np.ones(7))


def test_corrupt_mesh_file_is_a_clear_error(tmp_path):
    """meshio exits the process on an unreadable .msh; we turn that into a ValueError."""
    from sphfem.fem.substrate import FEMSubstrate

    bad = tmp_path / "corrupt.msh"
    bad.write_text("this is not a mesh\n")
    with pytest.raises(ValueError, match="could not be read"):
        FEMSubstrate(bad, E=300e9, nu=0.21, alpha=8.1e-6)


@pytest.mark.parametrize("element", ["tri", "quad"])
def test_recipe_names_faces_of_a_micrometre_box(tmp_path, monkeypatch, element):
    """Regression: gmsh pads bounding boxes by ~1e-7 model units, 0.2 % of a 0.1 mm thick
    box, and the face naming skipped the bottom line; faces come from exact corners now."""
    import meshio

    from sphfem.fem.meshing import substrate_rect

    monkeypatch.setenv("SPHFEM_CACHE", str(tmp_path))
    path = substrate_rect(size=(0.8e-3, 0.1e-3), origin=(-0.4e-3, -0.1e-3), h_fine=2e-5,
                          h_coarse=1e-4, refine_center=(0.0, 0.0), refine_radius=0.2e-3,
                          element=element)
    names = set(meshio.read(path).field_data)
    assert {"top", "bottom", "left", "right", "substrate"} <= names
