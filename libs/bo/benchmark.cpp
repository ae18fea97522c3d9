#include "bo/benchmark.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <random>

namespace maptune::bo {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}
double cpu_seconds_since(std::clock_t start) {
    return static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
}
}  // namespace

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    const std::size_t m = v.size() / 2;
    return v.size() % 2 == 1 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

RegretRun run_regret(const TestFunction& fn, int budget, int q, OptimizerOptions options,
                     std::uint64_t seed) {
    options.seed = seed;
    options.direction = Direction::minimize;
    Optimizer opt(fn.space, options);
    RegretRun run;
    double best = std::numeric_limits<double>::infinity();
    int evaluated = 0;
    while (evaluated < budget) {
        const int batch = std::min(q, budget - evaluated);
        run.ask_observations.push_back(evaluated);
        const auto start = Clock::now();
        const std::vector<Proposal> proposals = opt.ask(batch);
        run.ask_seconds.push_back(seconds_since(start));
        for (const Proposal& p : proposals) {
            const double value = fn.f(p.values);
            opt.tell(p.id, value);
            best = std::min(best, value);
            run.regret.push_back(best - fn.minimum);
            ++evaluated;
        }
    }
    return run;
}

RegretSummary summarize(const std::string& function, const std::string& acquisition, int q,
                        const std::vector<RegretRun>& runs, const std::vector<int>& checkpoints) {
    RegretSummary s;
    s.function = function;
    s.acquisition = acquisition;
    s.q = q;
    s.seeds = static_cast<int>(runs.size());
    s.checkpoints = checkpoints;
    std::size_t budget = 0;
    std::vector<double> ask_ms;
    for (const RegretRun& r : runs) {
        budget = std::max(budget, r.regret.size());
        for (double t : r.ask_seconds) {
            ask_ms.push_back(1e3 * t);
            s.total_seconds += t;
        }
    }
    for (std::size_t e = 0; e < budget; ++e) {
        std::vector<double> v;
        for (const RegretRun& r : runs) {
            if (e < r.regret.size()) v.push_back(r.regret[e]);
        }
        s.median_curve.push_back(median(v));
    }
    for (int c : checkpoints) {
        const auto e = static_cast<std::size_t>(c - 1);
        s.median_regret.push_back(e < s.median_curve.size() ? s.median_curve[e] : std::nan(""));
    }
    std::vector<double> finals;
    for (const RegretRun& r : runs) {
        if (!r.regret.empty()) finals.push_back(r.regret.back());
    }
    s.finals = finals;
    if (!finals.empty()) {
        std::sort(finals.begin(), finals.end());
        const auto k =
            static_cast<std::size_t>(std::ceil(0.9 * static_cast<double>(finals.size())));
        s.final_p90 = finals[std::max<std::size_t>(k, 1) - 1];
        s.final_max = finals.back();
    }
    s.median_ask_ms = median(ask_ms);
    s.max_ask_ms = ask_ms.empty() ? 0.0 : *std::max_element(ask_ms.begin(), ask_ms.end());
    return s;
}

AskTiming time_ask(int n, int dim, int repeats, OptimizerOptions options) {
    const TestFunction fn = log_rosenbrock(dim);
    std::mt19937_64 rng(options.seed + 12345);
    std::uniform_real_distribution<double> u(-2.0, 2.0);
    std::vector<Observation> history;
    for (int i = 0; i < n; ++i) {
        Observation o;
        for (int j = 0; j < dim; ++j) o.values.push_back(u(rng));
        o.value = fn.f(o.values);
        history.push_back(o);
    }
    options.direction = Direction::minimize;
    Optimizer opt(fn.space, options, history);
    AskTiming t;
    t.n = n;
    t.dim = dim;
    auto start = Clock::now();
    std::clock_t cpu_start = std::clock();
    std::vector<Proposal> p = opt.ask(1);
    t.first_ask_seconds = seconds_since(start);
    t.first_ask_cpu_seconds = cpu_seconds_since(cpu_start);
    std::vector<double> times;
    for (int r = 0; r < repeats; ++r) {
        // Withdraw the pending point so that every ask sees n observations and no refit.
        opt.cancel(p.front().id);
        start = Clock::now();
        p = opt.ask(1);
        times.push_back(seconds_since(start));
    }
    t.median_ask_seconds = median(times);
    opt.cancel(p.front().id);
    times.clear();
    for (int r = 0; r < repeats; ++r) {
        start = Clock::now();
        cpu_start = std::clock();
        p = opt.ask(1);
        times.push_back(seconds_since(start));
        if (times.back() >= t.running_max_seconds) {
            t.running_max_seconds = times.back();
            t.running_max_cpu_seconds = cpu_seconds_since(cpu_start);
        }
        opt.tell(p.front().id, fn.f(p.front().values));
    }
    t.running_median_seconds = median(times);
    return t;
}

GpTiming time_gp(int n, int dim, int predict_points, gp::CholeskyBackend backend, bool full_fit,
                 int threads) {
    const TestFunction fn = log_rosenbrock(dim);
    std::mt19937_64 rng(99);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Eigen::MatrixXd x(dim, n);
    Eigen::VectorXd y(n);
    for (int i = 0; i < n; ++i) {
        std::vector<double> v;
        for (int j = 0; j < dim; ++j) {
            x(j, i) = u(rng);
            v.push_back(-2.0 + 4.0 * x(j, i));
        }
        y(i) = fn.f(v);
    }
    GpTiming t;
    t.n = n;
    t.dim = dim;
    t.backend = gp::to_string(backend);
    gp::GpOptions options;
    options.backend = backend;
    options.threads = threads;
    gp::GaussianProcess model(dim, options);
    auto start = Clock::now();
    model.set_data(x, y);
    t.factorize_seconds = seconds_since(start);

    start = Clock::now();
    std::clock_t cpu_start = std::clock();
    const gp::FitResult fit = model.fit(1);
    t.fit_seconds = seconds_since(start);
    t.fit_cpu_seconds = cpu_seconds_since(cpu_start);
    t.fit_evaluations = fit.evaluations;
    if (full_fit) {
        // Every fit judged by the same yardstick: the posterior of all n points.
        const Eigen::VectorXd ystd = (y.array() - model.output_offset()) / model.output_scale();
        auto full_nlp = [&](const gp::Hyperparameters& hp) {
            return gp::neg_log_posterior(x, ystd, hp.to_log(), options.fit, nullptr, backend);
        };
        t.fit_nlp = full_nlp(fit.hyperparameters);
        // A fresh model fitted with `o`: its wall seconds and full-data posterior.
        auto timed_fit = [&](const gp::GpOptions& o, double& seconds, double& nlp) {
            gp::GaussianProcess m(dim, o);
            m.set_data(x, y);
            const auto begin = Clock::now();
            const gp::FitResult r = m.fit(1);
            seconds = seconds_since(begin);
            nlp = full_nlp(r.hyperparameters);
        };
        gp::GpOptions subset = options;
        subset.fit.full_data_refine = false;
        timed_fit(subset, t.fit_subset_seconds, t.fit_subset_nlp);
        gp::GpOptions full = options;
        full.fit.max_points = n;
        timed_fit(full, t.fit_full_seconds, t.fit_full_nlp);
    }

    std::vector<double> appends;
    for (int r = 0; r < 5; ++r) {
        Eigen::VectorXd p(dim);
        for (int j = 0; j < dim; ++j) p(j) = u(rng);
        start = Clock::now();
        model.append(p, 0.0);
        appends.push_back(seconds_since(start));
        model.truncate(n);
    }
    t.append_seconds = median(appends);

    Eigen::MatrixXd xs(dim, predict_points);
    for (Eigen::Index i = 0; i < xs.size(); ++i) xs.data()[i] = u(rng);
    Eigen::VectorXd mean, var;
    start = Clock::now();
    cpu_start = std::clock();
    model.predict(xs, mean, var);
    t.predict_seconds = seconds_since(start);
    t.predict_cpu_seconds = cpu_seconds_since(cpu_start);
    t.predict_points = predict_points;
    return t;
}

}  // namespace maptune::bo
