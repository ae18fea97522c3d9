#!/usr/bin/env python3
"""Share of the model's proposals that scored p = 0 (issue 15 item 2), from repeated runs.

    python3 bench/optimize/dead_share.py runs/dead/on runs/dead/off [--markdown] [--evaluations 40]

Each argument is a repeated `maptune run --seeds ...` directory (one seed-<n> directory per
seed) or a single run directory. Counts the evaluations with origin "model" or "quadratic" (after the
initial design and start points) whose p is 0 or that failed, and the best p of each run.
"""
import argparse
import csv
import os
import sys


def run_dirs(path):
    seeds = [d for d in os.listdir(path) if d.startswith("seed-") and os.path.isdir(os.path.join(path, d))]
    seeds.sort(key=lambda d: (len(d), d))  # seed-2 before seed-10
    if seeds:
        return [(d, os.path.join(path, d)) for d in seeds]
    return [(os.path.basename(path.rstrip("/")), path)]


def summarize(run_dir, evaluations=0):
    with open(os.path.join(run_dir, "trials.csv")) as f:
        rows = list(csv.DictReader(f))
    if evaluations > 0:
        rows = rows[:evaluations]  # a run continued with a larger budget, read at the smaller one
    model = [r for r in rows if r["origin"] in ("model", "quadratic")]
    dead = [r for r in model if r["failed"] == "1" or float(r["p"]) <= 0.0]
    best = max((float(r["p"]) for r in rows if r["failed"] != "1"), default=0.0)
    return len(dead), len(model), best, len(rows)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dirs", nargs="+")
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--evaluations", type=int, default=0, help="only the first N evaluations of each run")
    args = parser.parse_args()
    if args.markdown:
        print("| runs | zero-score model proposals (per seed) | all | best p (per seed) |")
        print("|---|---|---|---|")
    for path in args.dirs:
        if not os.path.isdir(path):
            sys.exit(f"dead_share: {path}: not a directory")
        per = [(name, *summarize(d, args.evaluations)) for name, d in run_dirs(path)]
        dead = sum(p[1] for p in per)
        model = sum(p[2] for p in per)
        share = 100.0 * dead / model if model else 0.0
        counts = " / ".join(f"{p[1]} of {p[2]}" for p in per)
        bests = " / ".join(f"{p[3]:.4f}" for p in per)
        if args.markdown:
            print(f"| {path} | {counts} | {share:.0f} % | {bests} |")
        else:
            print(f"{path}: {dead} of {model} model proposals scored 0 ({share:.1f} %); best p {bests}")


if __name__ == "__main__":
    main()
