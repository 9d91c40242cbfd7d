#!/usr/bin/env python
"""Summary over several compare.py runs (each one a complete same-run comparison).

    python benchmarks/pysph/summarize.py benchmarks/pysph/runs/run*_results.json \
        benchmarks/pysph/results.json > benchmarks/pysph/SUMMARY.md

For every (case, threads, our R): the ratio ours/PySPH in each run (particle-steps/s,
with our search amortised), and the ratio of the best figure of each code over all runs
(minimum step time = least disturbed by the other processes on the shared machine).
"""

from __future__ import annotations

import json
import sys


def cpu_ratio(rows):
    c = [r for _, r in rows if "cpu_particle_steps_per_s" in r["ours"]]
    if not c:
        return "-"
    o = max(r["ours"]["cpu_particle_steps_per_s"] for r in c)
    p = max(r["pysph"]["cpu_particle_steps_per_s"] for r in c)
    return f"{o / p:.2f}"


def main(paths):
    runs = [json.load(open(p)) for p in paths]
    keys = []
    per = {}
    for k, res in enumerate(runs):
        for r in res["comparison"]:
            key = (r["name"], r["case"], r["threads"], r["R_over_dx"])
            if key not in per:
                keys.append(key)
                per[key] = []
            per[key].append((k, r))
    out = ["# sphfem vs PySPH: summary over runs\n",
           "Runs (date, load average at start -> end):\n"]
    for p, res in zip(paths, runs, strict=True):
        out.append(f"* `{p}`: {res['date']}, load {res['loadavg_start']} -> "
                   f"{res['loadavg_end']}, git `{res['git_head'][:12]}`")
    out.append("\nRatio = ours / PySPH particle-steps/s (ours with the neighbour rebuild "
               "amortised over 4 steps); pairs/s ratio in brackets.  *best*: the best "
               "figure of each code over all runs.  CPU-time ratio: the same from process CPU "
               "time instead of wall time (1 thread: insensitive to the other processes; 2 "
               "threads: includes OpenMP spin-waiting).\n")
    out.append("| case | threads | ours R | ratio per run: p-steps (pairs/s) | best ours "
               "p-steps/s | best PySPH p-steps/s | **best ratio p-steps** | best ours "
               "pairs/s | best PySPH pairs/s | **best ratio pairs/s** | CPU-time ratio p-steps "
               "(runs that have it; best of each code) |")
    out.append("|" + "---|" * 11)
    for key in keys:
        rows = per[key]
        each = ", ".join(f"{r['ratio_particle_steps']:.2f} ({r['ratio_pairs']:.2f})"
                         for _, r in rows)
        bo = max(rows, key=lambda kr: kr[1]["ours"]["particle_steps_per_s"])[1]["ours"]
        bp = max(rows, key=lambda kr: kr[1]["pysph"]["particle_steps_per_s"])[1]["pysph"]
        out.append(
            f"| {key[1]} ({key[0]}) | {key[2]} | {key[3]:g} dx | {each} | "
            f"{bo['particle_steps_per_s']:.3e} | {bp['particle_steps_per_s']:.3e} | "
            f"**{bo['particle_steps_per_s'] / bp['particle_steps_per_s']:.2f}** | "
            f"{bo['pairs_per_s']:.3e} | {bp['pairs_per_s']:.3e} | "
            f"**{bo['pairs_per_s'] / bp['pairs_per_s']:.2f}** | {cpu_ratio(rows)} |")
    print("\n".join(out))


if __name__ == "__main__":
    main(sys.argv[1:])
