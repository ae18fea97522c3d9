#!/usr/bin/env python3
"""Seven test objectives (9-D; Michalewicz 10-D, Powell 8-D) the optimizer was not developed on, for
bench/optimize/compare.py: `objective.py NAME` reads a parameter set {"x1": …} as JSON on
stdin and prints the value. Spaces: NAME.yaml beside this file; minima: run.sh."""
import json
import math
import sys


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
    sys.exit(f"objective.py: unknown function '{name}'")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: objective.py NAME < set.json")
    p = json.loads(sys.stdin.read())
    print(repr(value(sys.argv[1], [p[f"x{i + 1}"] for i in range(len(p))])))
