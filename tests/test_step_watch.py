"""The collapsed-step detector (sphfem.step_watch) alone and in the driver's summary."""

import json

import pytest

from sphfem.step_watch import StepCollapseWatch


def _feed(w, dts, limiter="fluid.acoustic"):
    return [w.observe(1e-9 * k, dt, limiter) for k, dt in enumerate(dts)]


def test_a_tenfold_drop_that_lasts_is_one_episode():
    w = StepCollapseWatch(factor=0.1, steps=50, memory=1000)
    out = _feed(w, [1e-9] * 500 + [5e-11] * 300)
    reported = [(k, e) for k, e in enumerate(out) if e is not None]
    assert len(reported) == 1  # once per episode
    k, ep = reported[0]
    assert k == 500 + 49  # after 50 collapsed steps
    assert ep["limiter"] == "fluid.acoustic" and ep["dt"] == 5e-11
    assert ep["reference_dt"] == pytest.approx(1e-9, rel=1e-12)  # frozen in a collapse
    assert w.episodes == [ep] and ep["steps"] == 300 and ep["min_dt"] == 5e-11


def test_short_dips_and_mild_drops_are_not_episodes():
    w = StepCollapseWatch(factor=0.1, steps=50, memory=1000)
    # a 40-step dip (shorter than ``steps``), then a lasting drop to 0.2 of the reference
    assert not any(_feed(w, [1e-9] * 200 + [1e-11] * 40 + [1e-9] * 200 + [2e-10] * 500))
    assert w.episodes == []


def test_two_separate_episodes_and_bad_limits():
    w = StepCollapseWatch(factor=0.1, steps=10, memory=10_000)
    _feed(w, [1e-9] * 100 + [1e-11] * 20 + [1e-9] * 50 + [1e-11] * 30)
    assert [e["steps"] for e in w.episodes] == [20, 30]
    assert w.observe(0.0, float("nan"), "x") is None and w.observe(0.0, 0.0, "x") is None
    with pytest.raises(ValueError, match="factor"):
        StepCollapseWatch(factor=1.5)


def test_summary_lists_no_collapse_on_a_steady_run(tmp_path):
    from test_simulation import _scene_text

    from sphfem.scene import parse_scene_toml
    from sphfem.simulation import Simulation

    sim = Simulation(parse_scene_toml(_scene_text(), "mem.toml"))
    sim.run(tmp_path, progress=False)
    d = json.loads((tmp_path / "summary.json").read_text())
    assert d["dt"]["collapses"] == []
