"""Command line: ``sphfem run | validate | bench | optimize``.

Exit codes: 0 success, 1 a validation case failed its criteria or a run stopped on a
stability guard, 2 usage errors (bad arguments, malformed scene, existing output folder).
User errors are printed as one line on stderr, never as a traceback.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


class UsageError(Exception):
    """A mistake of the user's (arguments, scene, output folder): one line, exit code 2."""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="sphfem",
        description="Coupled SPH-FEM multiphysics: droplet deposition, heat and substrate stress.",
    )
    p.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    r = sub.add_parser("run", help="run a scene file", description="Run a TOML scene.")
    r.add_argument("scene", help="scene file (.toml), see docs/scenes.md")
    r.add_argument("--out", required=True, help="output folder (summary.json, VTU/PVD series)")
    r.add_argument("--overwrite", action="store_true", help="replace an existing output folder")
    r.add_argument("--resume", action="store_true",
                   help="continue from the last checkpoint in the output folder")
    r.add_argument("--no-progress", action="store_true",
                   help="hide the progress bar and the set-up stage lines (stderr)")
    r.add_argument("--keep-checkpoint", action="store_true",
                   help="keep checkpoint.npz after a completed run (deleted by default)")
    r.add_argument("--json", action="store_true",
                   help="print the run's key figures as one JSON line instead of the "
                        "human summary")

    v = sub.add_parser("validate", help="run a named validation case",
                       description="Run a validation case at several resolutions and variants.")
    v.add_argument("case", nargs="?",
                   help="case name (see --list), 'all' with --out, or 'stability' (the "
                        "stiff/extreme-case matrix)")
    v.add_argument("--only", metavar="ROWS",
                   help="with 'stability': comma-separated row names to run")
    v.add_argument("--list", action="store_true", help="list the available cases")
    v.add_argument("--quick", action="store_true", help="fewer / coarser resolutions")
    v.add_argument("--json", metavar="FILE", help="write the results as JSON")
    v.add_argument("--plot", metavar="FILE", help="write an error-versus-wall-time PNG")
    v.add_argument("--out", metavar="DIR",
                   help="with 'all': folder for report.md and each case's JSON and PNG")
    v.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    v.add_argument("--update-readme", metavar="README",
                   help="with 'all' or 'stability': write the table into README's marked "
                        "block")
    v.add_argument("--no-warmup", action="store_true",
                   help="time the runs without the untimed warm-up (numba compilation and "
                        "first-use costs then fall into the first timed run)")

    b = sub.add_parser("bench", help="throughput benchmarks",
                       description="Throughput: neighbour search, summation density, fluid steps.")
    b.add_argument("name",
                   help="benchmark: neighbors | density | dambreak2d | dambreak3d | droplet3d")
    b.add_argument("--json", metavar="FILE", help="write the figures as JSON")
    b.add_argument("--quick", action="store_true", help="small sizes (for smoke tests)")

    o = sub.add_parser("optimize", help="optimise a direct-ink-writing toolpath on Dask",
                       description="Toolpath optimisation of an extrusion scene (issue 18, "
                                   "docs/diw.md): one Dask task per evaluation, cached.")
    o.add_argument("scene", help="extrusion scene (.toml) with an optional [optimize] section")
    o.add_argument("--out", required=True, help="output folder (cache, history, report)")
    o.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler (default: a "
                   "LocalCluster of --workers processes)")
    o.add_argument("--workers", type=int, default=1, help="LocalCluster workers (default 1)")
    o.add_argument("--budget", type=int, help="evaluations (overrides [optimize] budget)")
    o.add_argument("--method", choices=("pso", "cma", "de"), help="overrides [optimize]")
    o.add_argument("--evaluator", choices=("extrusion", "lag-model"),
                   help="overrides [optimize]: lag-model is the cheap analytic stand-in")
    o.add_argument("--resume", action="store_true", help="continue in an existing --out")
    o.add_argument("--no-progress", action="store_true", help="hide the progress bar")

    sub.add_parser("mesh", help="write a gmsh substrate mesh (sphfem mesh block --help)",
                   add_help=False)
    return p


def _cmd_validate(args) -> int:
    from sphfem.validation import (
        format_table,
        load_cases,
        run_case,
        work_precision_plot,
        write_json,
    )

    cases = load_cases()
    if args.list:
        for name, fn in sorted(cases.items()):
            doc = (fn.__doc__ or "").strip().splitlines()
            print(f"{name:<20} {doc[0] if doc else ''}")
        from sphfem.validation.stability import ROWS

        print(f"{'all':<20} every case above into --out DIR/report.md")
        print(f"{'stability':<20} the stiff/extreme-case matrix ({len(ROWS)} rows, "
              "--only ROW,ROW):")
        for r in ROWS:
            print(f"  {r.name:<30} {r.description}")
        return EXIT_OK
    if not args.case:
        raise UsageError("validate: give a case name or --list")
    if args.case == "all":
        return _validate_all(args)
    if args.case == "stability":
        return _validate_stability(args)
    if args.case not in cases:
        raise UsageError(f"validate: unknown case {args.case!r}; known: {', '.join(sorted(cases))}")
    result = run_case(args.case, args.quick, warmup=not args.no_warmup)
    print(format_table(result))
    if args.json:
        write_json(result, args.json)
    if args.plot:
        work_precision_plot(result, args.plot)
    return EXIT_OK if result.passed else EXIT_FAIL


def _validate_all(args) -> int:
    from pathlib import Path

    from sphfem.output import OutputExistsError, prepare_output_dir
    from sphfem.validation.report import run_all, update_readme

    if not args.out:
        raise UsageError("validate all: give --out DIR for the report")
    try:
        out = prepare_output_dir(args.out, overwrite=args.overwrite)
    except OutputExistsError as e:
        raise UsageError(str(e)) from None
    print("| case | verdict | wall s |\n|---|---|---|", flush=True)
    ok, summary = run_all(Path(out), args.quick, warmup=not args.no_warmup,
                          progress=lambda line: print(line, flush=True))
    if args.update_readme:
        update_readme(Path(args.update_readme), summary, args.quick)
    print(f"report: {Path(out) / 'report.md'}")
    cells = [[c.strip() for c in line.strip("|").split("|")] for line in summary[2:]]
    print("PASSED" if ok else "FAILED: " + ", ".join(f"{c[0]} ({c[1]})" for c in cells
                                                    if c[1] != "passed"))
    return EXIT_OK if ok else EXIT_FAIL


def _validate_stability(args) -> int:
    from pathlib import Path

    from sphfem.output import OutputExistsError, atomic_write_text, prepare_output_dir, write_json
    from sphfem.validation import stability

    names = [r.name for r in stability.ROWS]
    rows = None
    if args.only:
        rows = [s.strip() for s in args.only.split(",") if s.strip()]
        unknown = [r for r in rows if r not in names]
        if unknown:
            raise UsageError(f"validate stability: unknown row(s) {', '.join(unknown)}; "
                             f"known: {', '.join(names)}")
    out = None
    if args.out:
        try:
            out = prepare_output_dir(args.out, overwrite=args.overwrite)
        except OutputExistsError as e:
            raise UsageError(str(e)) from None
    results = stability.run_matrix(
        args.quick, None if out is None else Path(out) / "runs", rows,
        progress=lambda r: print(stability.text_line(r), flush=True))
    report = stability.to_json(results, args.quick)
    if out is not None:
        atomic_write_text(Path(out) / "stability.md", stability.markdown(results, args.quick))
        write_json(Path(out) / "stability.json", report)
        print(f"report: {Path(out) / 'stability.md'}")
    if args.json:
        write_json(args.json, report)
    if args.update_readme:
        from sphfem.validation.report import STABILITY_BEGIN, STABILITY_END, update_readme

        update_readme(Path(args.update_readme), stability.table(results), args.quick,
                      case="stability", begin=STABILITY_BEGIN, end=STABILITY_END)
    bad = [r.name for r in results if not r.passed]
    print("PASSED" if not bad else f"FAILED: {', '.join(bad)}")
    return EXIT_OK if not bad else EXIT_FAIL


def _cmd_bench(args) -> int:
    from sphfem.bench import BENCHMARKS, run_bench
    from sphfem.output import write_json

    if args.name not in BENCHMARKS:
        raise UsageError(f"bench: unknown benchmark {args.name!r}; known: {', '.join(BENCHMARKS)}")
    res = run_bench(args.name, quick=args.quick)
    if args.json:
        write_json(args.json, res)
    return EXIT_OK


def _cmd_run(args) -> int:
    """``sphfem run``: :func:`sphfem.api.run`, with the command line's wording and exit codes."""
    from sphfem import api
    from sphfem.errors import OutputExistsError, OutputFolderError, SceneError
    from sphfem.jit_warmup import warm_up
    from sphfem.output import prepare_output_dir
    from sphfem.simulation import format_summary

    try:
        scene = api.load_scene(args.scene)
        # refused in the command line's words (--overwrite); api.run checks again (a no-op)
        prepare_output_dir(args.out, check_only=True, overwrite=args.overwrite,
                           resume=args.resume)
        # a cold numba cache: compile in a child first, so this process never holds the
        # compiler's memory (issue 14; sphfem/jit_warmup.py)
        warm_up(scene, progress=not args.no_progress)
        res = api.run(scene, args.out, overwrite=args.overwrite, resume=args.resume,
                      progress=not args.no_progress, keep_checkpoint=args.keep_checkpoint)
    except (SceneError, OutputExistsError, OutputFolderError) as e:
        raise UsageError(str(e)) from None
    except api.RunStopped as e:
        print(f"sphfem: run stopped: {e}", file=sys.stderr)
        return EXIT_FAIL
    if args.json:
        keys = ("status", "steps", "t", "setup_s", "wall_s", "total_s", "peak_rss_mb")
        print(json.dumps({k: res.summary[k] for k in keys if k in res.summary}))
    else:
        print(format_summary(res.summary, res.out))
    return EXIT_OK


def _cmd_optimize(args) -> int:
    from sphfem.diw.driver import command
    from sphfem.errors import OutputExistsError, SceneError

    try:
        return command(args)
    except (SceneError, OutputExistsError) as e:
        raise UsageError(str(e)) from None


def main(argv=None) -> int:
    parser = _parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["mesh"]:  # the mesh recipes own their argument parser
        from sphfem.fem.meshing import mesh_command

        return mesh_command(argv[1:])
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # argparse already printed its one-line usage error
        return EXIT_USAGE if e.code else EXIT_OK
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    if args.command is None:
        parser.print_help()
        return EXIT_USAGE
    handler = {"run": _cmd_run, "validate": _cmd_validate, "bench": _cmd_bench,
               "optimize": _cmd_optimize}[args.command]
    try:
        return handler(args)
    except UsageError as e:
        print(f"sphfem: error: {e}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
