"""[coupling] backend = "fem-dynamic" from a scene (coupling/backend_fem_dynamic.py through
the coupled driver): a slowly heated substrate tends to the quasi-static answer, and the
scene keys of the elastodynamic substrate are checked."""

from __future__ import annotations

import re

import numpy as np
import pytest
from test_coupling import HOT  # hot water block on alumina, heat + coupling, no forces


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SPHFEM_CACHE", str(tmp_path / "cache"))


def test_slow_thermal_loading_tends_to_the_quasi_static_substrate(tmp_path, cache):
    """The hot block warms the alumina over t_end = 0.6 ms; the substrate's slowest mode
    (clamped layer 0.25 mm thick, c_S = 5.6 km/s) has T1 = 4 h / c_S = 0.18 us, so the
    loading is ~3000 T1 slow and the dynamic response must equal the quasi-static one up to
    the ramp amplification T1 / (pi t_r) <= 3e-4 for the 0.2 ms coupling intervals
    (sphfem.fem.elastodynamic): the run's peak von Mises and the last mean stress within
    1e-3 of the quasi-static run's (measured 5e-7 and 3e-8 with Newmark, 3e-7 and 2e-8 with
    HHT -1/3); the first solve starts from rest in equilibrium under the load present at
    t = 0 (it raised before)."""
    from sphfem.api import run
    from sphfem.scene import parse_scene_toml

    qs = run(parse_scene_toml(HOT), tmp_path / "qs")
    ref = qs.summary["diagnostics"]["coupling"]
    S_ref = np.array(list(ref["last"]["mean_stress"].values()))
    assert ref["peak_von_mises_Pa"] > 1e5  # the substrate is loaded
    for alpha in (0.0, -1.0 / 3.0):
        dyn = HOT.replace("[coupling]\n", f'[coupling]\nbackend = "fem-dynamic"\n'
                                          f"hht_alpha = {alpha!r}\n")
        res = run(parse_scene_toml(dyn), tmp_path / f"dyn{alpha:.2f}")
        c = res.summary["diagnostics"]["coupling"]
        assert c["backend"]["backend"] == "fem-dynamic"
        assert c["solves"] == ref["solves"]
        assert c["peak_von_mises_Pa"] == pytest.approx(ref["peak_von_mises_Pa"], rel=1e-3)
        S = np.array(list(c["last"]["mean_stress"].values()))
        assert np.abs(S - S_ref).max() < 1e-3 * np.abs(S_ref).max()


@pytest.mark.parametrize("old, new, key", [
    ("[coupling]\n", '[coupling]\nhht_alpha = -0.1\n', "coupling.hht_alpha"),
    ("[coupling]\n", '[coupling]\nbackend = "fem-dynamic"\nhht_alpha = -0.5\n',
     "coupling.hht_alpha"),
    ("[coupling]\n", '[coupling]\nbackend = "fem-dynamic"\nmass = "diagonal"\n',
     "coupling.mass"),
])
def test_dynamic_scene_keys_are_checked(old, new, key):
    from sphfem.scene import SceneError, parse_scene_toml

    with pytest.raises(SceneError, match=re.escape(key)):
        parse_scene_toml(HOT.replace(old, new))
