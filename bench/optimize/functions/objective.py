#!/usr/bin/env python3
"""Eleven test objectives (9-D; Michalewicz 10-D, Powell 8-D) the optimizer was not developed on, for
bench/optimize/compare.py: `objective.py NAME` reads a parameter set {"x1": …} as JSON on
stdin and prints the value; `objective.py --space NAME` prints its design space YAML and
`objective.py --minimum NAME` its known minimum (run.sh uses both)."""
import json
import math
import sys

# name: (dimension, lower bound, upper bound, known minimum)
FUNCTIONS = {
    "rastrigin": (9, -5.12, 5.12, 0.0),
    "schwefel": (9, -500.0, 500.0, 0.0),
    "michalewicz": (10, 0.0, math.pi, -9.66015),
    "griewank": (9, -50.0, 50.0, 0.0),
    "dixon_price": (9, -10.0, 10.0, 0.0),
    "zakharov": (9, -5.0, 10.0, 0.0),
    "powell": (8, -4.0, 5.0, 0.0),
    # Added 2026-12-07 as a check of the quadratic steps, first run after them (BENCHMARKS.md).
    "rotated_ellipsoid": (9, -65.0, 65.0, 0.0),
    "trid": (9, -81.0, 81.0, -156.0),
    "alpine": (9, -10.0, 10.0, 0.0),
    "sum_powers": (9, -1.0, 1.0, 0.0),
}


def shift(i, span):
    """A fixed, irregular offset of the optimum inside the box (not at its centre)."""
    return span * (((i + 1) * 0.6180339887) % 1.0 - 0.5)


def value(name, x):
    d = len(x)
    if name == "rastrigin":  # multi-modal on a bowl, optimum shifted
        z = [xi - shift(i, 4.0) for i, xi in enumerate(x)]
        return 10 * d + sum(zi * zi - 10 * math.cos(2 * math.pi * zi) for zi in z)
    if name == "schwefel":  # deceptive: the best basins lie far apart, near the bounds
        return 418.9828872724338 * d - sum(xi * math.sin(math.sqrt(abs(xi))) for xi in x)
    if name == "michalewicz":  # steep narrow valleys (m = 20); its space is 10-D, minimum -9.66015
        return -sum(math.sin(xi) * math.sin((i + 1) * xi * xi / math.pi) ** 20 for i, xi in enumerate(x))
    if name == "griewank":  # many shallow local minima, optimum shifted
        z = [xi - shift(i, 40.0) for i, xi in enumerate(x)]
        return 1 + sum(zi * zi for zi in z) / 4000 - math.prod(
            math.cos(zi / math.sqrt(i + 1)) for i, zi in enumerate(z))
    if name == "dixon_price":  # curved valley, values over orders of magnitude
        return (x[0] - 1) ** 2 + sum((i + 1) * (2 * x[i] ** 2 - x[i - 1]) ** 2 for i in range(1, d))
    if name == "zakharov":  # a quartic along one oblique direction: a rotated valley
        s = sum(0.5 * (i + 1) * xi for i, xi in enumerate(x))
        return sum(xi * xi for xi in x) + s ** 2 + s ** 4
    if name == "powell":  # singular Hessian at the optimum, coupled quadruples
        v = 0.0
        for k in range(d // 4):
            a, b, c, e = x[4 * k:4 * k + 4]
            v += (a + 10 * b) ** 2 + 5 * (c - e) ** 2 + (b - 2 * c) ** 4 + 10 * (a - e) ** 4
        return v
    if name == "rotated_ellipsoid":  # Schwefel 1.2: squares of running sums, strongly non-separable
        total, c = 0.0, 0.0
        for i, xi in enumerate(x):
            c += xi - shift(i, 30.0)
            total += c * c
        return total
    if name == "trid":  # a bowl coupled along neighbours; minimum -d(d+4)(d-1)/6
        return sum((xi - 1) ** 2 for xi in x) - sum(x[i] * x[i - 1] for i in range(1, d))
    if name == "alpine":  # non-smooth, multi-modal, optimum shifted
        return sum(abs(z * math.sin(z) + 0.1 * z) for z in (xi - shift(i, 8.0) for i, xi in enumerate(x)))
    if name == "sum_powers":  # different powers per axis: flat near the optimum, optimum shifted
        return sum(abs(xi - shift(i, 1.0)) ** (i + 2) for i, xi in enumerate(x))
    raise ValueError(f"unknown function '{name}'")


def space_yaml(name):
    d, low, high, _ = FUNCTIONS[name]
    lines = [f"name: {name}", "parameters:"]
    lines += [f"  x{i + 1}: {{type: float, low: {low!r}, high: {high!r}, default: 0, decimals: 6}}"
              for i in range(d)]
    return "\n".join(lines)


if __name__ == "__main__":
    args = sys.argv[1:]
    if len(args) == 2 and args[0] in ("--space", "--minimum") and args[1] in FUNCTIONS:
        print(space_yaml(args[1]) if args[0] == "--space" else FUNCTIONS[args[1]][3])
    elif len(args) == 1 and args[0] in FUNCTIONS:
        p = json.loads(sys.stdin.read())
        print(repr(value(args[0], [p[f"x{i + 1}"] for i in range(len(p))])))
    else:
        sys.exit("usage: objective.py NAME < set.json | objective.py --space NAME | objective.py --minimum NAME"
                 " (NAME: " + ", ".join(FUNCTIONS) + ")")
