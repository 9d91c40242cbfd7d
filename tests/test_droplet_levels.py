"""The droplet-impact case's levels (the residual-film rule) and its per-speed criteria on
manufactured figure sequences f(h) = f0 + C h^p, where the Richardson limit is known."""

from __future__ import annotations

import math

import pytest

from sphfem.fluid.spreading import MIN_FILM_PARTICLES, residual_film
from sphfem.validation import droplet_impact as di


def test_levels_put_three_particles_across_the_residual_film():
    """Packaged water droplet (D = 0.1 mm, mu = 3e-4 Pa s): the finest level is the first
    rung with >= 3 particles across h_res = 0.79 D Re^-0.4, the rung below has fewer."""
    D, rho, mu = 1e-4, 1000.0, 3e-4
    expected = {10.0: (64, 90, 128), 30.0: (90, 128, 181), 50.0: (128, 181, 256)}
    for V, levels in expected.items():
        assert di.levels_for(V) == levels
        h = residual_film(D, rho * V * D / mu)
        assert h * levels[-1] / D >= MIN_FILM_PARTICLES > h * levels[-2] / D
    with pytest.raises(ValueError, match="needs more than"):
        di.levels_for(1e4)


def manufactured(levels, speed, C, p=1.0):
    """Figures of ``levels`` with every figure f0 (1 + C (h/D)^p), f0 inside every band."""
    f0 = {"spread": 3.3, "heat": 5e-5, "T_impact": 19.0, "vm_peak": 5e7}
    figs = []
    for n in levels:
        e = 1.0 + C * (1.0 / n) ** p
        f = {k: v * e for k, v in f0.items()}
        f.update(tc=1e-4 / speed, t_end=4e-4 / speed, spread_t_tc=2.5, balance=1e-14,
                 T_impact_dev=0.02, wagner_ratio=1.02, correlations=(3.09, 3.54), We=139.0,
                 Re=3333.0, lamella_particles=5.0, film_particles=3.9, vm_thermal=5.08e7,
                 vm_t_tc=2.0, vm_r_m=0.0, vm_z_m=0.0, heat_ideal=7e-5, T_impact_static=0.2,
                 strain_tc=1.0)
        figs.append(f)
    return figs


def test_speed_criteria_pass_near_the_limit_and_fail_far_from_it():
    """Levels 64, 90, 128 with first-order errors: C = 2 (finest 1.6 % off the limit,
    error bar 2 %) converges; C = 40 (31 % off) does not; the limit is recovered either way."""
    levels = (64, 90, 128)
    crit, notes = di.speed_criteria(10.0, levels, manufactured(levels, 10.0, 2.0))
    assert all(c.passed for c in crit.values()), {k: c.value for k, c in crit.items()}
    assert any("limit 3.3 " in x or "limit 3.3 +-" in x for x in notes), notes
    crit, _ = di.speed_criteria(10.0, levels, manufactured(levels, 10.0, 40.0))
    for key in di.FIGURES:
        assert not crit[f"10 m/s {key} converged"].passed
    # the spread is then 1 + 40/128 = 1.31 x 3.3 = 4.33, outside the band widened by 10 %
    assert not crit["10 m/s correlations"].passed
    assert crit["10 m/s correlations"].value == pytest.approx(4.33125 / 3.54 - 1.0)


def test_speed_criteria_quick_gates_only_balance_and_contact():
    levels = (16, 20, 24)
    crit, _ = di.speed_criteria(50.0, levels, manufactured(levels, 50.0, 40.0), quick=True)
    assert set(crit) == {"50 m/s balance", "50 m/s contact T"}
    assert math.isclose(crit["50 m/s balance"].value, 1e-14)


def _convergence_script():
    import importlib.util
    from pathlib import Path

    path = Path(__file__).parents[1] / "examples" / "droplet_impact" / "convergence.py"
    spec = importlib.util.spec_from_file_location("droplet_convergence", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_convergence_script_reads_levels_from_an_earlier_json(tmp_path, capsys):
    """convergence.py --figures-from: levels whose figures are in an earlier
    convergence_V*.json are not run again, and the criteria come out as from the file's own
    figures; a file of another speed or end time is refused."""
    import json

    conv = _convergence_script()
    levels = (64, 90, 128)
    figs = manufactured(levels, 10.0, C=0.5)
    for f in figs:
        f.update(t_end=4.0 * f["tc"], wall_s=1.0, correlations=list(f["correlations"]))
    src = tmp_path / "earlier.json"
    src.write_text(json.dumps({"speed": 10.0, "levels": list(levels), "figures": figs}))
    out = tmp_path / "out"
    rc = conv.main(["10", "--out", str(out), "--levels", *map(str, levels),
                    "--t-end-tc", "4", "--figures-from", str(src)])
    printed = capsys.readouterr().out
    assert printed.count("figures from") == 3
    assert not any(p.is_dir() for p in out.iterdir())  # nothing was run
    res = json.loads((out / "convergence_V10.json").read_text())
    crit, _ = di.speed_criteria(10.0, levels, figs)
    assert rc == (0 if all(c.passed for c in crit.values()) else 1)
    assert {k: v["passed"] for k, v in res["criteria"].items()} == {
        k: bool(c.passed) for k, c in crit.items()}
    with pytest.raises(SystemExit, match="ended at 4 t_c, not 6"):
        conv.main(["10", "--out", str(out), "--levels", *map(str, levels),
                   "--t-end-tc", "6", "--figures-from", str(src)])
    with pytest.raises(SystemExit, match="speed 10.0 m/s, not 30"):
        conv.main(["30", "--out", str(out), "--levels", *map(str, levels),
                   "--t-end-tc", "4", "--figures-from", str(src)])
