#!/usr/bin/env python3
# Reference for the GP fit timing (BENCHMARKS.md, issue 15): needs Debian python3-sklearn;
# run with /usr/bin/python3 bench/gp/sklearn_fit.py.
# scikit-learn's GP fit on the same kind of data as bo_bench's timing (n = 1000, d = 9):
# Matern-5/2 ARD times a constant, plus white noise, one L-BFGS-B run (no restarts).
import time, numpy as np
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import Matern, ConstantKernel, WhiteKernel
rng = np.random.default_rng(2)
n, d = 1000, 9
x = rng.uniform(size=(n, d))
y = np.sin(3 * x[:, 0]) + x[:, 1] * x[:, 2] - x[:, 3]
for rep in range(2):
    k = ConstantKernel(1.0, (1e-2, 1e2)) * Matern(length_scale=np.ones(d), length_scale_bounds=(1e-2, 1e2), nu=2.5) + WhiteKernel(1e-3, (1e-6, 1.0))
    g = GaussianProcessRegressor(kernel=k, normalize_y=True, n_restarts_optimizer=0, random_state=0)
    t0 = time.time(); g.fit(x, y); t1 = time.time()
    print(f"sklearn fit n={n} d={d}: {t1 - t0:.2f} s, log marginal likelihood {g.log_marginal_likelihood_value_:.1f}")
