"""One level of the droplet-impact validation scene with overrides (the runs of the
wall-friction study in docs/validation/droplet_impact/README.md, session 9).

    python examples/droplet_impact/level_run.py V N T_END_TC OUT [--wall-radius R] [--resume]
                                                [--fluid-only] [--every TC] [key=value ...]

V the impact speed [m/s] (c0 = 10 V), N particles across the droplet, T_END_TC the end time in
t_c = D / V; ``--wall-radius`` widens the SPH wall, the domain and the lateral heat refinement
to r = R [m] (the packaged scene: 0.3 mm); ``section.key=value`` overrides a scene key, e.g.
``fluid.wall_friction=layer`` or ``fluid.alpha=0.01``; ``--resume`` continues from OUT's
checkpoint when there is one (the run writes one at every output and keeps the last, so a
completed level can be continued to a later T_END_TC; without the flag an existing OUT is
overwritten); ``--fluid-only`` runs the fluid alone (no heat, no substrate: the cheap way to
look at the flow, e.g. the axis frames of ``axis_frames.py``); ``--every`` writes the
particles every TC t_c (default T_END_TC / 4).  Prints the validation's figures of the
run (:func:`sphfem.validation.droplet_impact.figures`; with ``--fluid-only`` the summary's
fluid figures).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


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
    ap.add_argument("overrides", nargs="*", help="section.key=value")
    a = ap.parse_intermixed_args(argv)

    from sphfem.api import run
    from sphfem.scene import parse_scene
    from sphfem.validation import droplet_impact as di

    d = di.scene_at(a.speed, a.per_diameter, a.t_end_tc, wall_radius=a.wall_radius,
                    overrides=a.overrides)
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
    run(scene, a.out, resume=resume, overwrite=not resume, keep_checkpoint=True)
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
