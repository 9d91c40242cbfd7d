"""VTU series compression (sphfem.output.VTUSeries.compression): raw by default, zlib on
request; both read back to the same arrays bit for bit."""

import meshio
import numpy as np

from sphfem.output import ParticleSeries


def test_vtu_compression_roundtrip(tmp_path):
    rng = np.random.default_rng(0)
    x = rng.normal(size=(50, 2))
    T = rng.uniform(size=50)
    mesh = meshio.Mesh(np.column_stack([x, np.zeros(50)]),
                       [("vertex", np.arange(50).reshape(-1, 1))], point_data={"T": T})
    raw = ParticleSeries(tmp_path / "raw")
    packed = ParticleSeries(tmp_path / "zlib")
    packed.compression = "zlib"
    f_raw = raw.write_mesh(0.0, mesh)
    f_zlib = packed.write_mesh(0.0, mesh)
    assert 'compressor="vtkZLibDataCompressor"' in f_zlib.read_text()
    assert "compressor" not in f_raw.read_text()
    for f in (f_raw, f_zlib):
        m = meshio.read(f)
        assert np.array_equal(m.points[:, :2], x) and np.array_equal(m.point_data["T"], T)
