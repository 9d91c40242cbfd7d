"""Run SPlisHSPlasH's DamBreakModel scene without GUI and print its timing as one JSON line.

Run with the Python of a venv that has ``pysplishsplash`` (PyPI), not the project's; see
README.md.  The scene is SPlisHSPlasH's ``data/Scenes/DamBreakModel.json`` (commit c5a063dd)
written out with the particle radius and the pressure method chosen here (the PyPI wheel
ships no scene files): a 1 m fluid cube in a 4 x 3 x 1.5 m box (a wall volume map,
Bender et al. 2019), cubic spline kernel, standard viscosity nu = 0.01 m^2/s, CFL step
0.4 (2r) / v_max capped at 5 ms.

    OMP_NUM_THREADS=2 LD_PRELOAD=/lib/x86_64-linux-gnu/libGLdispatch.so.0 \
        /work/venvs/splash/bin/python run_splishsplash.py --method dfsph --radius 0.0125 --stop-at 1

(the preload avoids a crash at import on Debian, where the wheel's bundled libGLdispatch
meets the system's libGLX).  Timed: ``runSimulation`` alone (volume-map generation and
particle set-up excluded); per step the time-step size and the solver iterations.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

#: DamBreakModel.json of SPlisHSPlasH (commit c5a063dd), the keys that matter here
METHODS = {"dfsph": 4, "iisph": 3}


def unit_box_obj() -> str:
    """A closed unit cube [-0.5, 0.5]^3 as an OBJ mesh (12 outward-facing triangles)."""
    v = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
    # vertex index = 4 ix + 2 iy + iz + 1; two triangles per face, counter-clockwise seen
    # from outside
    f = [(1, 2, 4), (1, 4, 3), (5, 7, 8), (5, 8, 6), (1, 5, 6), (1, 6, 2),
         (3, 4, 8), (3, 8, 7), (1, 3, 7), (1, 7, 5), (2, 6, 8), (2, 8, 4)]
    return "".join(f"v {a} {b} {c}\n" for a, b, c in v) + "".join(
        f"f {a} {b} {c}\n" for a, b, c in f)


def scene(method: str, radius: float, max_error: float, max_error_v: float) -> dict:
    """The DamBreakModel scene with ``method`` (dfsph | iisph) and ``radius``."""
    cfg = {
        "particleRadius": radius,
        "numberOfStepsPerRenderUpdate": 4,
        "simulationMethod": METHODS[method],
        "gravitation": [0, -9.81, 0],
        "timeStepSize": 0.005,
        "cflMethod": 1,
        "cflFactor": 1,
        "cflMaxTimeStepSize": 0.005,
        "boundaryHandlingMethod": 2,
        "DFSPH": {"minIterations": 2, "maxIterations": 100, "maxError": max_error,
                  "maxIterationsV": 100, "maxErrorV": max_error_v,
                  "enableDivergenceSolver": True},
        "IISPH": {"minIterations": 2, "maxIterations": 100, "maxError": max_error},
    }
    return {
        "Configuration": cfg,
        "Materials": [{"id": "Fluid", "density0": 1000, "viscosityMethod": 1,
                       "Standard viscosity": {"viscosity": 0.01}}],
        "RigidBodies": [{"geometryFile": "../models/UnitBox.obj", "translation": [0, 1.5, 0],
                         "rotationAxis": [1, 0, 0], "rotationAngle": 0,
                         "scale": [4, 3, 1.5], "isDynamic": False, "isWall": True,
                         "mapInvert": True, "mapThickness": 0.0,
                         "mapResolution": [40, 30, 15]}],
        "FluidBlocks": [{"denseMode": 0, "start": [-0.5, 0.0, -0.5], "end": [0.5, 1.0, 0.5],
                         "translation": [-1.45, 0.05, 0.0], "scale": [1, 1, 1]}],
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", choices=sorted(METHODS), default="dfsph")
    ap.add_argument("--radius", type=float, default=0.0125,
                    help="particle radius [m] (0.0125: 39^3 = 59,319 particles)")
    ap.add_argument("--stop-at", type=float, default=1.0, help="physical end time [s]")
    ap.add_argument("--max-error", type=float, default=0.05,
                    help="density-error tolerance [%%] (DamBreakModel: 0.05)")
    ap.add_argument("--max-error-v", type=float, default=0.1,
                    help="DFSPH divergence-error tolerance [%%] (DamBreakModel: 0.1)")
    ap.add_argument("--workdir", default=None, help="scene folder (default: a temp folder)")
    a = ap.parse_args(argv)

    import pysplishsplash as sph

    work = a.workdir or tempfile.mkdtemp(prefix="splash_")
    os.makedirs(os.path.join(work, "Scenes"), exist_ok=True)
    os.makedirs(os.path.join(work, "models"), exist_ok=True)
    with open(os.path.join(work, "models", "UnitBox.obj"), "w") as f:
        f.write(unit_box_obj())
    path = os.path.join(work, "Scenes", f"DamBreakModel_{a.method}.json")
    with open(path, "w") as f:
        json.dump(scene(a.method, a.radius, a.max_error, a.max_error_v), f, indent=1)

    base = sph.Exec.SimulatorBase()
    base.init(sceneFile=path, useGui=False, stopAt=a.stop_at, initialPause=False,
              outputDir=os.path.join(work, "output"))
    steps = {"dt": [], "it": [], "itv": []}

    def on_step():
        sim = sph.Simulation.getCurrent()
        ts = sim.getTimeStep()
        steps["dt"].append(sph.TimeManager.getCurrent().getTimeStepSize())
        steps["it"].append(ts.getValueInt(ts.SOLVER_ITERATIONS))
        if a.method == "dfsph":
            steps["itv"].append(ts.getValueInt(ts.SOLVER_ITERATIONS_V))

    base.setTimeStepCB(on_step)
    base.initSimulation()
    sim = sph.Simulation.getCurrent()
    n = sim.getFluidModel(0).numActiveParticles() if hasattr(
        sim.getFluidModel(0), "numActiveParticles") else sim.getFluidModel(0).getValueUInt(
        sph.FluidModel.NUM_PARTICLES)
    t0 = time.perf_counter()
    c0 = time.process_time()
    base.runSimulation()
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    t_end = sph.TimeManager.getCurrent().getTime()
    base.cleanup()
    nst = len(steps["dt"])
    out = {"code": "SPlisHSPlasH", "method": a.method, "fluid_particles": int(n),
           "radius": a.radius, "t_end": t_end, "steps": nst, "wall_s": wall, "cpu_s": cpu,
           "threads": os.environ.get("OMP_NUM_THREADS"),
           "mean_dt": t_end / nst if nst else None,
           "it_mean": sum(steps["it"]) / nst if nst else None,
           "it_max": max(steps["it"]) if nst else None,
           "particle_steps_per_s": n * nst / wall if wall > 0 else None,
           "tolerance_pct": a.max_error,
           "divergence_tolerance_pct": a.max_error_v if a.method == "dfsph" else None}
    if steps["itv"]:
        out["div_it_mean"] = sum(steps["itv"]) / nst
    print(json.dumps(out))
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
