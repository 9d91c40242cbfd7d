"""FEMSeries writes its VTU files itself (the mesh's points and cells encoded once per
mesh): the files are the same bytes as meshio's VTU writer makes of the same mesh and
fields, compressed (zlib at any level) or raw, at every write of a series."""

from __future__ import annotations

import meshio
import numpy as np
import pytest
from skfem import MeshQuad1, MeshTri1

from sphfem.fem import FEMSeries
from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate
from sphfem.fem.output import encode_data_array


def _substrate(cells: str):
    r = np.linspace(0.0, 1e-3, 9) ** 1.3 / 1e-3 ** 0.3
    z = np.linspace(-0.26e-3, 0.0, 6)
    mesh = (MeshTri1 if cells == "tri" else MeshQuad1).init_tensor(r, z)
    mesh = mesh.with_boundaries({"bottom": lambda x: np.isclose(x[1], -0.26e-3),
                                 "right": lambda x: np.isclose(x[0], 1e-3),
                                 "top": lambda x: np.isclose(x[1], 0.0)})
    return AxisymmetricFEMSubstrate(mesh, E=300e9, nu=0.21, alpha=7e-6, T0=293.15,
                                    clamps=["bottom", "right"])


def _solves(sub):
    nv = sub.mesh.nvertices
    rng = np.random.default_rng(3)
    out = []
    for k in range(3):
        dT = 40.0 * rng.random(nv) * np.exp(-sub.mesh.p[0] / 3e-4)
        out.append(sub.solve(dT_nodal=dT, tractions={"top": [1e5 * k, -1e6 * (k + 1)]}))
    return out


@pytest.mark.parametrize("cells", ["tri", "quad"])
@pytest.mark.parametrize("compression,level", [("zlib", 1), ("zlib", None), ("zlib", 6),
                                               (None, 1)])
def test_files_are_meshio_bytes(tmp_path, cells, compression, level):
    sub = _substrate(cells)
    ours, ref = FEMSeries(tmp_path / "ours"), FEMSeries(tmp_path / "ref")
    for ser in (ours, ref):
        ser.compression, ser.compression_level = compression, level
    for k, res in enumerate(_solves(sub)):
        p = ours.write(1e-6 * k, res)
        q = ref.write_mesh(1e-6 * k, ref._meshio_mesh(res))  # meshio's writer
        assert p.name == q.name == f"substrate_{k:05d}.vtu"
        assert p.read_bytes() == q.read_bytes()
    assert (tmp_path / "ours" / "substrate.pvd").read_bytes() == \
        (tmp_path / "ref" / "substrate.pvd").read_bytes()
    assert not any(f.name.startswith(".") for f in (tmp_path / "ours").iterdir())
    m = meshio.read(p)
    assert np.array_equal(m.point_data["von_mises"], res.von_mises_nodes)
    assert np.array_equal(m.cell_data["stress_elem"][0], res.stress_elem.reshape(-1, 9))


def test_lzma_goes_through_meshio(tmp_path):
    sub = _substrate("tri")
    res = _solves(sub)[0]
    ours, ref = FEMSeries(tmp_path / "ours"), FEMSeries(tmp_path / "ref")
    ours.compression = ref.compression = "lzma"
    assert ours.write(0.0, res).read_bytes() == \
        ref.write_mesh(0.0, ref._meshio_mesh(res)).read_bytes()


def test_a_new_mesh_is_encoded_anew(tmp_path):
    ser = FEMSeries(tmp_path)
    a, b = _substrate("tri"), _substrate("quad")
    ser.write(0.0, _solves(a)[0])
    ser.write(1.0, _solves(b)[0])
    m = meshio.read(tmp_path / "substrate_00001.vtu")
    assert m.cells[0].type == "quad" and len(m.points) == b.mesh.nvertices


def test_encoded_blocks():
    """The zlib layout: [blocks, block size, last block size, compressed sizes...] then
    the blocks, each 32 KiB of the data; empty data has no block."""
    import base64
    import zlib

    data = np.arange(10000, dtype=np.float64)  # 80,000 bytes: 3 blocks
    text = encode_data_array(data, "zlib", 1)
    head = np.frombuffer(base64.b64decode(text[:32]), np.uint32)
    assert head.tolist()[:3] == [3, 32768, 80000 - 2 * 32768]
    body = base64.b64decode(text[32:])
    out, pos = b"", 0
    for n in head[3:]:
        out += zlib.decompress(body[pos:pos + n])
        pos += n
    assert out == data.tobytes() and pos == len(body)
    raw = base64.b64decode(encode_data_array(data, None, None))
    assert np.frombuffer(raw[:4], np.uint32)[0] == 80000 and raw[4:] == data.tobytes()
    empty = base64.b64decode(encode_data_array(np.zeros(0), "zlib", 1))
    assert np.frombuffer(empty, np.uint32).tolist() == [0, 32768, 32768]


@pytest.mark.parametrize("cells", ["tri", "quad"])
def test_appended_layout_reads_back_the_same_arrays(tmp_path, cells):
    """``layout = "appended"`` (raw binary, no compression): meshio reads the arrays,
    points and cells of the inline file back, bit for bit."""
    sub = _substrate(cells)
    inline, appended = FEMSeries(tmp_path / "inline"), FEMSeries(tmp_path / "appended")
    appended.layout = "appended"
    for k, res in enumerate(_solves(sub)):
        a = meshio.read(inline.write(1e-6 * k, res))
        b = meshio.read(appended.write(1e-6 * k, res))
        assert np.array_equal(a.points, b.points)
        assert [c.type for c in a.cells] == [c.type for c in b.cells]
        assert all(np.array_equal(x.data, y.data) for x, y in zip(a.cells, b.cells,
                                                                  strict=True))
        assert list(a.point_data) == list(b.point_data)
        assert all(np.array_equal(a.point_data[n], b.point_data[n]) for n in a.point_data)
        assert list(a.cell_data) == list(b.cell_data)
        assert all(np.array_equal(a.cell_data[n][0], b.cell_data[n][0])
                   for n in a.cell_data)
    assert (tmp_path / "appended" / "substrate.pvd").read_bytes() == \
        (tmp_path / "inline" / "substrate.pvd").read_bytes()
    assert not any(f.name.startswith(".") for f in (tmp_path / "appended").iterdir())
    appended.layout = "zip"
    with pytest.raises(ValueError, match="layout"):
        appended.write(1.0, res)
