#!/usr/bin/env python3
"""Side-by-side regret of maptune optimize and Optuna's samplers on the same objective command.

Every optimizer evaluates the same command (a parameter set as JSON on stdin, a number on
stdout), so the comparison needs nothing but the command: a maptune test function
(`--function levy9`, evaluated by `maptune bo-bench --eval`) or any other objective with its
space and known minimum (`--space S.yaml --objective-cmd CMD --minimum V`).

    python3 bench/optimize/compare.py --function levy9 --function ackley9 --seeds 10 --budget 100
    python3 bench/optimize/compare.py --space my.yaml --objective-cmd 'python3 f.py' --minimum 0

Optuna (Debian python3-optuna, python3-cmaes) runs with its defaults; maptune optimize with
its defaults (--minimize). Prints median simple regret at 25/50/100 evaluations (and the 90th
percentile at the budget) per function and optimizer, a 95 % confidence interval of the median at
the budget (order statistics: with 10 seeds it spans the 2nd to the 9th value, with 30 the 10th
to the 21st), and for maptune against each other optimizer the chance that a maptune run ends
below a run of the other (Mann-Whitney, ties halved; 0.5 = no difference). --json writes every
curve. Medians of 10 seeds move by a factor of two between seed sets on some functions
(BENCHMARKS.md): compare with the interval, not the median alone.
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
DEFAULT_MAPTUNE = os.path.join(ROOT, "build", "release", "services", "maptune", "maptune")
# The standalone benchmark binary starts in ~5 ms (maptune, linked with PCL and Fast DDS, in
# ~60 ms): the test functions' objective command when it is built.
DEFAULT_EVALUATOR = os.path.join(ROOT, "build", "release", "bench", "bo", "bo_bench")


def read_space(path):
    """The float/int parameters of a design space YAML (the subset of YAML maptune writes)."""
    import yaml  # python3-yaml, a dependency of optuna's Debian package
    with open(path) as f:
        doc = yaml.safe_load(f)
    out = []
    for name, spec in doc["parameters"].items():
        out.append((name, spec["type"], float(spec["low"]), float(spec["high"]), bool(spec.get("log_scale", False))))
    return out


def evaluate(command, params):
    p = subprocess.run(command, shell=True, input=json.dumps(params) + "\n", capture_output=True, text=True)
    if p.returncode != 0:
        return None
    try:
        return float(p.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return None


def best_so_far(values):
    out, best = [], float("inf")
    for v in values:
        if v is not None and v < best:
            best = v
        out.append(best)
    return out


def run_maptune(maptune, space_file, command, budget, seed):
    with tempfile.TemporaryDirectory(prefix="maptune_compare_") as tmp:
        run_dir = os.path.join(tmp, "run")
        subprocess.run([maptune, "optimize", "--space", space_file, "--objective-cmd", command, "--minimize",
                        "--budget", str(budget), "--seed", str(seed), "--run-dir", run_dir],
                       check=True, capture_output=True, text=True)
        values = []
        with open(os.path.join(run_dir, "trials.csv")) as f:
            header = f.readline().strip().split(",")
            i_p, i_failed = header.index("p"), header.index("failed")
            for line in f:
                cells = line.rstrip("\n").split(",")
                values.append(None if cells[i_failed] == "1" else float(cells[i_p]))
        return values


def run_optuna(sampler_name, space, command, budget, seed):
    import optuna
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    sampler = {"cmaes": lambda: optuna.samplers.CmaEsSampler(seed=seed),
               "tpe": lambda: optuna.samplers.TPESampler(seed=seed),
               "random": lambda: optuna.samplers.RandomSampler(seed=seed)}[sampler_name]()
    values = []

    def objective(trial):
        params = {}
        for name, kind, low, high, log in space:
            if kind == "int":
                params[name] = trial.suggest_int(name, int(low), int(high), log=log)
            else:
                params[name] = trial.suggest_float(name, low, high, log=log)
        v = evaluate(command, params)
        values.append(v)
        if v is None:
            raise optuna.TrialPruned()  # a failed evaluation
        return v

    study = optuna.create_study(direction="minimize", sampler=sampler)
    study.optimize(objective, n_trials=budget, catch=(Exception,))
    return values


def median_interval(sorted_values, level=0.95):
    """Distribution-free interval of the median: ranks k and n-k+1 with P(Bin(n, 1/2) < k) <= (1-level)/2."""
    n = len(sorted_values)
    k, tail = 0, 0.0
    while k < n:
        nxt = tail + math.comb(n, k) / 2 ** n  # P(B <= k)
        if nxt > (1 - level) / 2:
            break
        tail, k = nxt, k + 1
    if k == 0:  # too few values for the level: the whole range
        return sorted_values[0], sorted_values[-1]
    return sorted_values[k - 1], sorted_values[n - k]


def chance_below(a, b):
    """P(a run of A ends below a run of B): the Mann-Whitney statistic over all pairs, ties halved."""
    wins = sum((x < y) + 0.5 * (x == y) for x in a for y in b)
    return wins / (len(a) * len(b))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--function", action="append", default=[], help="maptune test function (repeatable)")
    ap.add_argument("--space", help="design space YAML of --objective-cmd")
    ap.add_argument("--objective-cmd", help="objective command (minimized)")
    ap.add_argument("--minimum", type=float, help="known minimum of --objective-cmd (regret = best - minimum)")
    ap.add_argument("--name", default="objective", help="row name for --objective-cmd")
    ap.add_argument("--optimizers", default="maptune,cmaes,tpe", help="comma list of maptune, cmaes, tpe, random")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--budget", type=int, default=100)
    ap.add_argument("--maptune", default=DEFAULT_MAPTUNE)
    ap.add_argument("--evaluator", default=None,
                    help="binary with --eval/--write-space for --function (default: bench/bo's bo_bench, else maptune bo-bench)")
    ap.add_argument("--json", help="write all curves to this file")
    a = ap.parse_args()

    problems = []
    tmp = tempfile.mkdtemp(prefix="maptune_compare_spaces_")
    evaluator = [a.evaluator] if a.evaluator else (
        [DEFAULT_EVALUATOR] if os.path.exists(DEFAULT_EVALUATOR) else [a.maptune, "bo-bench"])
    for fn in a.function:
        space_file = os.path.join(tmp, fn + ".yaml")
        text = subprocess.run(evaluator + ["--write-space", fn], check=True, capture_output=True,
                              text=True).stdout
        with open(space_file, "w") as f:
            f.write(text)
        minimum = float(text.split("minimum ", 1)[1].split("\n", 1)[0])
        problems.append((fn, space_file, " ".join(f"'{x}'" for x in evaluator) + f" --eval {fn}", minimum))
    if a.objective_cmd:
        if a.space is None or a.minimum is None:
            ap.error("--objective-cmd needs --space and --minimum")
        problems.append((a.name, a.space, a.objective_cmd, a.minimum))
    if not problems:
        ap.error("give --function or --objective-cmd")

    checkpoints = [c for c in (25, 50, 100, a.budget) if c <= a.budget]
    checkpoints = sorted(set(checkpoints))
    results = []
    print("| function | optimizer | seeds | " + " | ".join(f"regret@{c}" for c in checkpoints) +
          f" | 95 % interval of the median@{a.budget} | p90@{a.budget} | max@{a.budget} |")
    print("|---|---|---|" + "---|" * (len(checkpoints) + 3))
    for name, space_file, command, minimum in problems:
        space = read_space(space_file)
        for opt in a.optimizers.split(","):
            curves = []
            for s in range(a.first_seed, a.first_seed + a.seeds):
                if opt == "maptune":
                    values = run_maptune(a.maptune, space_file, command, a.budget, s)
                else:
                    values = run_optuna(opt, space, command, a.budget, s)
                curve = [v - minimum for v in best_so_far(values)]
                curves.append(curve)
                print(f"  {name} {opt} seed {s}: regret {curve[-1]:.4g}", file=sys.stderr)
            final = sorted(c[-1] for c in curves)
            med = [statistics.median(c[k - 1] for c in curves) for k in checkpoints]
            p90 = final[min(len(final) - 1, int(0.9 * (len(final) - 1) + 0.5))]
            lo, hi = median_interval(final)
            print(f"| {name} | {opt} | {len(curves)} | " + " | ".join(f"{m:.3g}" for m in med) +
                  f" | {lo:.3g} … {hi:.3g} | {p90:.3g} | {final[-1]:.3g} |", flush=True)
            results.append({"function": name, "optimizer": opt, "checkpoints": checkpoints, "median_regret": med,
                            "median_interval_final": [lo, hi], "p90_final": p90, "curves": curves})
    print_chances(results)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f)


def print_chances(results):
    """maptune against every other optimizer on the same function: P(maptune's run ends lower)."""
    rows = []
    for r in results:
        if r["optimizer"] == "maptune":
            continue
        m = next((x for x in results if x["function"] == r["function"] and x["optimizer"] == "maptune"), None)
        if m:
            p = chance_below([c[-1] for c in m["curves"]], [c[-1] for c in r["curves"]])
            rows.append(f"| {r['function']} | {r['optimizer']} | {p:.2f} |")
    if rows:
        print("\n| function | against | P(maptune ends lower) |\n|---|---|---|")
        print("\n".join(rows))


if __name__ == "__main__":
    main()
