"""Where a step of the axisymmetric droplet job goes: process-CPU seconds per pass.

    python benchmarks/axisymmetric_step_profile.py V N TEND OUT [key=value ...] [--cprofile P]

runs one level of the droplet-impact validation scene (as examples/droplet_impact/level_run.py:
``sphfem.validation.droplet_impact.scene_at(V, N, TEND)`` with ``section.key=value``
overrides, e.g. ``fluid.wall_friction=layer``) into OUT and prints a table of process-CPU
seconds per step of every numba kernel of the axisymmetric fluid, heat and coupling modules
(each dispatcher wrapped by a timer in every module that holds it; the arithmetic is
untouched) and of the main Python methods (inclusive), the share of the stepping loop's
CPU, and the modules' totals.  Writes OUT/profile.json.  ``--cprofile P`` also writes a
cProfile dump (timer: process CPU) of the stepping loop; ``--substrate-layout appended``
writes the substrate VTU files as raw appended binary (``sphfem.fem.FEMSeries.layout``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

#: modules whose numba dispatchers are timed
KERNEL_MODULES = ("sphfem.fluid.axisymmetric", "sphfem.fluid.axisymmetric_surface_tension",
                  "sphfem.fluid.wall_layer", "sphfem.fluid.no_penetration",
                  "sphfem.fluid.surface", "sphfem.heat.axisymmetric", "sphfem.axisymmetric_scene",
                  "sphfem.neighbors", "coupling.heat_interface", "coupling.substrate_heat",
                  "coupling.transfer", "coupling.sensors", "sphfem.fluid.axisymmetric_step")
#: Python methods timed (inclusive): (module, class, method)
METHODS = (
    ("sphfem.fluid.axisymmetric", "AxisymmetricFluid", "step"),
    ("sphfem.fluid.axisymmetric", "AxisymmetricFluid", "evaluate"),
    ("sphfem.fluid.axisymmetric", "AxisymmetricFluid", "_shift"),
    ("sphfem.fluid.axisymmetric", "AxisymmetricFluid", "_reflect"),
    ("sphfem.fluid.axisymmetric", "AxisymmetricFluid", "_layer_inputs"),
    ("sphfem.fluid.axisymmetric", "AxisymmetricFluid", "_advance_layer"),
    ("sphfem.fluid.axisymmetric", "AxisymmetricFluid", "_mirrors"),
    ("sphfem.fluid.axisymmetric", "AxisymmetricFluid", "dt_limits"),
    ("sphfem.fluid.axisymmetric_surface_tension", "AxisymmetricCSF", "accumulate"),
    ("sphfem.fluid.no_penetration", "NoPenetration", "apply"),
    ("sphfem.axisymmetric_scene", "AxisymmetricFluidModule", "step"),
    ("sphfem.axisymmetric_scene", "AxisymmetricFluidModule", "_write_back"),
    ("sphfem.axisymmetric_scene", "AxisymmetricFluidModule", "_correction_forces"),
    ("sphfem.axisymmetric_scene", "AxisymmetricFluidModule", "contact_diameter"),
    ("sphfem.axisymmetric_scene", "AxisymmetricHeatModule", "step"),
    ("sphfem.axisymmetric_scene", "AxisymmetricHeatModule", "_system"),
    ("sphfem.axisymmetric_scene", "AxisymmetricHeatModule", "_rates"),
    ("coupling.driver", "CouplingModule", "step"),
    ("coupling.driver", "CouplingDriver", "couple"),
    ("coupling.substrate_heat", "SubstrateHeat", "exchange"),
    ("coupling.heat_interface", "ContactHeatInterface", "step"),
    ("sphfem.fem.heat_transient", "TransientHeat", "step"),
    ("coupling.backends", "FEMBackend", "solve"),
    ("coupling.backends", "FEMBackend", "write"),
    ("coupling.driver", "CouplingDriver", "_record"),
    ("coupling.driver", "CouplingDriver", "write_history"),
    ("coupling.driver", "CouplingModule", "checkpoint_state"),
    ("sphfem.simulation", "Simulation", "save_checkpoint"),
)


def install_timers(acc: dict) -> None:
    """Wrap every numba dispatcher of KERNEL_MODULES (in every loaded sphfem / coupling
    module that holds it) and the METHODS with process-CPU timers adding into ``acc``
    {name: [seconds, calls]}."""
    import importlib

    from numba.core.registry import CPUDispatcher

    def timer(f, name):
        def timed(*a, **k):
            t0 = time.process_time()
            try:
                return f(*a, **k)
            finally:
                e = acc.setdefault(name, [0.0, 0])
                e[0] += time.process_time() - t0
                e[1] += 1

        timed.__wrapped__ = f
        return timed

    for name in KERNEL_MODULES:  # loaded first, so their callers' names are seen below
        try:
            importlib.import_module(name)
        except ImportError:
            pass
    # dispatchers called from other numba functions stay as they are (a compiled caller
    # resolves its globals when it is typed)
    inner = set()
    for mod in list(sys.modules.values()):
        if getattr(mod, "__name__", "").startswith(("sphfem", "coupling")):
            for f in list(vars(mod).values()):
                if isinstance(f, CPUDispatcher):
                    inner.update(f.py_func.__code__.co_names)
    wrapped = {}
    for name in KERNEL_MODULES:
        try:
            mod = importlib.import_module(name)
        except ImportError:
            continue
        for attr, f in vars(mod).items():
            if (isinstance(f, CPUDispatcher) and f.py_func.__module__ == name
                    and attr not in inner):
                wrapped[id(f)] = timer(f, f"{name.rsplit('.', 1)[-1]}.{attr}")
    for mod in list(sys.modules.values()):
        if not getattr(mod, "__name__", "").startswith(("sphfem", "coupling")):
            continue
        for attr, f in list(vars(mod).items()):
            if isinstance(f, CPUDispatcher) and id(f) in wrapped:
                setattr(mod, attr, wrapped[id(f)])
    for modname, cls, meth in METHODS:
        c = getattr(importlib.import_module(modname), cls)
        if meth in vars(c):  # the class's own method (a subclass would call it twice)
            setattr(c, meth, timer(getattr(c, meth), f"{cls}.{meth}"))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("speed", type=float)
    ap.add_argument("per_diameter", type=int)
    ap.add_argument("t_end_tc", type=float)
    ap.add_argument("out", type=Path)
    ap.add_argument("--cprofile", type=Path, default=None)
    ap.add_argument("--substrate-layout", choices=("inline", "appended"), default=None,
                    help="sphfem.fem.FEMSeries.layout of the substrate VTU files (default: "
                         "the class's, inline zlib)")
    ap.add_argument("overrides", nargs="*", help="section.key=value")
    a = ap.parse_intermixed_args(argv)

    import numba

    from sphfem.output import prepare_output_dir
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation
    from sphfem.validation import droplet_impact as di

    scene = parse_scene(di.scene_at(a.speed, a.per_diameter, a.t_end_tc,
                                    overrides=a.overrides),
                        source="benchmarks/axisymmetric_step_profile")
    import coupling.driver  # noqa: F401  (loaded, so its dispatchers can be wrapped)
    import coupling.substrate_heat  # noqa: F401
    import sphfem.axisymmetric_scene  # noqa: F401
    import sphfem.fluid.axisymmetric  # noqa: F401

    if a.substrate_layout is not None:
        from sphfem.fem import FEMSeries

        FEMSeries.layout = a.substrate_layout
    acc: dict = {}
    install_timers(acc)
    prepare_output_dir(a.out, overwrite=True)
    sim = Simulation(scene, source="benchmarks/axisymmetric_step_profile")
    acc.clear()  # the set-up's calls (the first evaluation, compilation) do not count
    prof = None
    if a.cprofile is not None:
        import cProfile

        prof = cProfile.Profile(time.process_time)
        prof.enable()
    c0, w0 = time.process_time(), time.perf_counter()
    s = sim.run(a.out, progress=False)
    c1, w1 = time.process_time(), time.perf_counter()
    if prof is not None:
        prof.disable()
        prof.dump_stats(a.cprofile)
    steps, n = s["steps"], s["particles"]["total"]
    cpu = c1 - c0
    rec = {"V": a.speed, "N": a.per_diameter, "t_end_tc": a.t_end_tc,
           "overrides": a.overrides, "substrate_layout": a.substrate_layout,
           "threads": numba.get_num_threads(), "particles": n,
           "steps": steps, "run_cpu_s": cpu, "run_wall_s": w1 - w0,
           "cpu_ms_per_step": 1e3 * cpu / steps,
           "particle_steps_per_cpu_s": n * steps / cpu,
           "wall_s_per_module": s["wall_s_per_module"],
           "timers": {k: {"cpu_s": v[0], "calls": v[1], "ms_per_step": 1e3 * v[0] / steps}
                      for k, v in sorted(acc.items(), key=lambda kv: -kv[1][0])}}
    (a.out / "profile.json").write_text(json.dumps(rec, indent=1))
    print(f"{n} particles, {steps} steps, {cpu:.2f} CPU-s ({rec['cpu_ms_per_step']:.2f} "
          f"CPU-ms/step, {rec['particle_steps_per_cpu_s']:.4g} particle-steps per CPU-s), "
          f"wall {w1 - w0:.1f} s, threads {rec['threads']}")
    print(f"{'timer':48s} {'CPU s':>8s} {'calls':>7s} {'ms/step':>8s} {'share':>6s}")
    for k, v in rec["timers"].items():
        print(f"{k:48s} {v['cpu_s']:8.3f} {v['calls']:7d} {v['ms_per_step']:8.3f} "
              f"{100 * v['cpu_s'] / cpu:5.1f}%")


if __name__ == "__main__":
    main()
