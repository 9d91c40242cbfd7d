"""One level of the droplet-impact validation scene with overrides (the runs of the
wall-friction study in docs/validation/droplet_impact/README.md, session 9).

    python examples/droplet_impact/level_run.py V N T_END_TC OUT [--wall-radius R] [--resume]
                                                [--fluid-only] [--every TC]
                                                [--fluid-option KEY=VALUE ...] [--member K]
                                                [key=value ...]

V the impact speed [m/s] (c0 = 10 V), N particles across the droplet, T_END_TC the end time in
t_c = D / V; ``--wall-radius`` widens the SPH wall, the domain and the lateral heat refinement
to r = R [m] (the packaged scene: 0.3 mm); ``section.key=value`` overrides a scene key, e.g.
``fluid.wall_friction=layer`` or ``fluid.alpha=0.01``; ``--resume`` continues from OUT's
checkpoint when there is one (the run writes one at every output and keeps the last, so a
completed level can be continued to a later T_END_TC; without the flag an existing OUT is
overwritten); ``--fluid-only`` runs the fluid alone (no heat, no substrate: the cheap way to
look at the flow, e.g. the axis frames of ``axis_frames.py``); ``--every`` writes the
particles every TC t_c (default the validation's 0.1; the steps do not land on the output
times, so the interval does not change the run); ``--fluid-option KEY=VALUE`` (repeatable)
overrides one of the axisymmetric fluid's treatment keywords
(:attr:`sphfem.axisymmetric_scene.AxisymmetricFluidModule.fluid_options`, e.g.
``wall_tension=False``, or any other keyword of
:class:`sphfem.fluid.axisymmetric.AxisymmetricFluid`; the value a Python literal) for this
run only; ``--member K`` runs the validation's ensemble member K (the droplet jittered by
1e-3 dx with seed K, :func:`sphfem.validation.droplet_impact.scene_at`).  Prints the
validation's figures of the run
(:func:`sphfem.validation.droplet_impact.figures`; with ``--fluid-only`` the summary's fluid
figures).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

#: AxisymmetricFluid keywords of other geometries (a periodic or planar strip, a wall plane):
#: not --fluid-option's to set, nor are those the module sets itself
#: (``AxisymmetricFluidModule.SCENE_KEYWORDS``: scene keys and class constants)
OTHER_GEOMETRIES = ("periodic_z", "planar", "wall_z")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("speed", type=float)
    ap.add_argument("per_diameter", type=int)
    ap.add_argument("t_end_tc", type=float)
    ap.add_argument("out", type=Path)
    ap.add_argument("--wall-radius", type=float, default=None)
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--fluid-only", action="store_true")
    ap.add_argument("--every", type=float, default=None, help="output interval [t_c]")
    ap.add_argument("--fluid-option", action="append", default=[], metavar="KEY=VALUE",
                    help="an AxisymmetricFluidModule.fluid_options keyword for this run")
    ap.add_argument("--member", type=int, default=0,
                    help="the validation's ensemble member (0: the scene as it is)")
    ap.add_argument("overrides", nargs="*", help="section.key=value")
    a = ap.parse_intermixed_args(argv)

    import ast
    import inspect

    from sphfem.axisymmetric_scene import AxisymmetricFluidModule
    from sphfem.fluid.axisymmetric import AxisymmetricFluid

    options = dict(AxisymmetricFluidModule.fluid_options)
    # the keywords the module sets from scene keys or its class constants are not options
    fixed = AxisymmetricFluidModule.SCENE_KEYWORDS | set(OTHER_GEOMETRIES)
    keywords = [p.name for p in inspect.signature(AxisymmetricFluid).parameters.values()
                if p.default is not p.empty and p.name not in fixed]
    for kv in a.fluid_option:
        key, sep, value = kv.partition("=")
        if not sep or key not in keywords:
            ap.error(f"--fluid-option {kv!r}: expected KEY=VALUE with KEY one of "
                     f"{sorted(keywords)}")
        try:
            options[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            ap.error(f"--fluid-option {kv!r}: the value is not a Python literal")

    from sphfem.api import run
    from sphfem.scene import parse_scene
    from sphfem.validation import droplet_impact as di

    if a.member < 0:
        ap.error(f"--member must be >= 0, got {a.member}")
    d = di.scene_at(a.speed, a.per_diameter, a.t_end_tc, wall_radius=a.wall_radius,
                    overrides=a.overrides, member=a.member)
    if a.fluid_only:
        d["physics"]["modules"] = ["fluid"]
        for key in ("heat", "coupling"):
            d.pop(key, None)
    if a.every is not None:
        if not a.every > 0.0:
            ap.error(f"--every must be > 0, got {a.every}")
        d["output"]["every"] = f"{a.every} tc"
    scene = parse_scene(d, source=f"level_run V={a.speed:g} D/dx={a.per_diameter}")
    resume = a.resume and (a.out / "checkpoint.npz").exists()
    default = AxisymmetricFluidModule.fluid_options
    AxisymmetricFluidModule.fluid_options = options  # for this run only
    try:
        run(scene, a.out, resume=resume, overwrite=not resume, keep_checkpoint=True)
    finally:
        AxisymmetricFluidModule.fluid_options = default
    summary = json.loads((a.out / "summary.json").read_text())
    drop = next(b for b in d["blocks"] if b["kind"] == "fluid")
    if a.fluid_only:
        fl = summary["diagnostics"]["fluid"]
        print(json.dumps({k: v for k, v in fl.items() if not isinstance(v, (list, dict))},
                         default=str, indent=1))
        return
    print(json.dumps(di.figures(summary, a.speed, 2.0 * drop["radius"]), default=str, indent=1))


if __name__ == "__main__":
    main()
