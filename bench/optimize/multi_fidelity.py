#!/usr/bin/env python3
"""Multi-fidelity against whole-view evaluation (issue 16 item 2), from two repeated runs.

    python3 bench/optimize/multi_fidelity.py --full runs/bench_mf/full_fidelity \
        --multi runs/bench_mf/multi_fidelity [--target heldout_label] [--markdown]

Each directory is a repeated `maptune run` (one seed-<n> directory per seed). Per seed:
- target: the best whole-view p the full-fidelity run reached in its budget, and when
  (trials.csv elapsed_s of the evaluation that first reached it);
- when the multi-fidelity run first reached that p with a whole-view evaluation (or that it did
  not, with its own best), the ratio of the two times;
- how many of its evaluations stopped on the subset, and its total time;
- the held-out p (validation.csv) of both runs' final best (set "best", what best_params.yaml
  holds) and of the model's predicted best (set "predicted", predicted_best.yaml).
The summary also gives the median time ratio over all seeds (a seed that never reached the target
counts as above any ratio) and the median held-out differences.
"""
import argparse
import csv
import os
import statistics
import sys


def read_trials(run_dir):
    with open(os.path.join(run_dir, "trials.csv")) as f:
        rows = list(csv.DictReader(f))
    out = []
    for r in rows:
        out.append({
            "p": float(r["p"]),
            "failed": r["failed"] == "1",
            "fidelity": int(r.get("fidelity") or 1),
            "elapsed_s": float(r.get("elapsed_s") or 0),
        })
    return out


def held_out(run_dir, label, which="best"):
    path = os.path.join(run_dir, "validation.csv")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        for r in csv.DictReader(f):
            if r["set"] == which and (label is None or r["target"] == label):
                return float(r["p"])
    return None


def first_reaching(trials, target):
    """elapsed_s of the first successful whole-view evaluation with p >= target."""
    for t in trials:
        if not t["failed"] and t["fidelity"] == 1 and t["p"] >= target - 1e-12:
            return t["elapsed_s"]
    return None


def seeds(parent):
    names = sorted((d for d in os.listdir(parent) if d.startswith("seed-")), key=lambda d: int(d[5:]))
    if not names:
        sys.exit(f"{parent}: no seed-<n> run directories")
    return names


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", required=True, help="repeated run directory, whole-view evaluation")
    ap.add_argument("--multi", required=True, help="repeated run directory, multi-fidelity")
    ap.add_argument("--target", default=None, help="validation target label (default: the first)")
    ap.add_argument("--markdown", action="store_true", help="a Markdown table")
    a = ap.parse_args()

    rows = []
    for seed in seeds(a.full):
        full = read_trials(os.path.join(a.full, seed))
        multi_dir = os.path.join(a.multi, seed)
        if not os.path.isdir(multi_dir):
            sys.exit(f"{multi_dir}: missing (run both arms with the same seeds)")
        multi = read_trials(multi_dir)
        ok = [t for t in full if not t["failed"] and t["fidelity"] == 1]
        target = max(t["p"] for t in ok)
        t_full = first_reaching(full, target)
        t_multi = first_reaching(multi, target)
        multi_best = max(t["p"] for t in multi if not t["failed"] and t["fidelity"] == 1)
        rows.append({
            "seed": seed[5:],
            "target_p": target,
            "t_full": t_full,
            "t_multi": t_multi,
            "ratio": (t_multi / t_full) if (t_multi is not None and t_full) else None,
            "multi_best": multi_best,
            "stopped": sum(1 for t in multi if t["fidelity"] != 1),
            "evaluations": len(multi),
            "total_full": full[-1]["elapsed_s"],
            "total_multi": multi[-1]["elapsed_s"],
            "heldout_full": held_out(os.path.join(a.full, seed), a.target),
            "heldout_multi": held_out(multi_dir, a.target),
            "predicted_full": held_out(os.path.join(a.full, seed), a.target, "predicted"),
            "predicted_multi": held_out(multi_dir, a.target, "predicted"),
        })

    def f(v, d=3):
        return "—" if v is None else f"{v:.{d}f}"

    header = ["seed", "full: best p", "full: reached at s", "multi: reached at s", "time ratio",
              "multi: best p", "stopped on subset", "full: total s", "multi: total s",
              "held-out p full", "held-out p multi", "held-out Δ", "predicted best: held-out Δ"]

    def diff(a_, b_):
        return None if None in (a_, b_) else a_ - b_

    lines = []
    for r in rows:
        delta = diff(r["heldout_multi"], r["heldout_full"])
        r["delta"], r["delta_predicted"] = delta, diff(r["predicted_multi"], r["predicted_full"])
        lines.append([r["seed"], f(r["target_p"], 4), f(r["t_full"], 0),
                      f(r["t_multi"], 0) if r["t_multi"] is not None else "not reached",
                      f(r["ratio"], 2), f(r["multi_best"], 4), f"{r['stopped']}/{r['evaluations']}",
                      f(r["total_full"], 0), f(r["total_multi"], 0), f(r["heldout_full"], 4),
                      f(r["heldout_multi"], 4), f(delta, 4), f(r["delta_predicted"], 4)])
    ratios = [r["ratio"] for r in rows if r["ratio"] is not None]
    summary = (f"median time ratio {statistics.median(ratios):.2f} over {len(ratios)} of {len(rows)} seeds that reached the target"
               if ratios else "no seed reached the full-fidelity best")
    # Over all seeds, a seed that never reached the target ranks above every ratio.
    ranked = sorted(r["ratio"] if r["ratio"] is not None else float("inf") for r in rows)
    overall = statistics.median(ranked)
    summary += (f"; over all {len(rows)} seeds: median ratio {'not reached' if overall == float('inf') else f'{overall:.2f}'}, "
                f"{sum(1 for v in ranked if v <= 0.5)} of {len(rows)} at most 0.5")
    for key, name in (("delta", "best observed"), ("delta_predicted", "predicted best")):
        ds = [r[key] for r in rows if r[key] is not None]
        if ds:
            summary += f"; held-out Δ of the {name}: median {statistics.median(ds):+.3f} ({min(ds):+.3f} … {max(ds):+.3f})"
    if a.markdown:
        print("| " + " | ".join(header) + " |")
        print("|" + "---|" * len(header))
        for l in lines:
            print("| " + " | ".join(l) + " |")
        print()
        print(summary)
    else:
        widths = [max(len(h), *(len(l[i]) for l in lines)) for i, h in enumerate(header)]
        print("  ".join(h.rjust(w) for h, w in zip(header, widths)))
        for l in lines:
            print("  ".join(c.rjust(w) for c, w in zip(l, widths)))
        print(summary)


if __name__ == "__main__":
    main()
