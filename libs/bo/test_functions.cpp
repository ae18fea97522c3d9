#include "bo/test_functions.hpp"

#include <cmath>
#include <limits>

namespace maptune::bo {

namespace {
double branin_value(double x1, double x2) {
    const double a = 1.0, b = 5.1 / (4.0 * M_PI * M_PI), c = 5.0 / M_PI, r = 6.0, s = 10.0,
                 t = 1.0 / (8.0 * M_PI);
    const double u = x2 - b * x1 * x1 + c * x1 - r;
    return a * u * u + s * (1.0 - t) * std::cos(x1) + s;
}
}  // namespace

TestFunction branin() {
    TestFunction fn;
    fn.name = "branin";
    fn.space = {{"x1", -5.0, 10.0, false, false}, {"x2", 0.0, 15.0, false, false}};
    fn.minimum = 0.397887357729738;
    fn.f = [](const std::vector<double>& x) { return branin_value(x[0], x[1]); };
    return fn;
}

TestFunction branin_integer() {
    TestFunction fn = branin();
    fn.name = "branin_integer";
    fn.space[1].is_integer = true;
    // Minimum over x2 in {0..15}: scan x1 finely for each integer x2.
    double best = std::numeric_limits<double>::infinity();
    for (int x2 = 0; x2 <= 15; ++x2) {
        for (int i = 0; i <= 150000; ++i) best = std::min(best, branin_value(-5.0 + 1e-4 * i, x2));
    }
    fn.minimum = best;
    return fn;
}

TestFunction hartmann6() {
    TestFunction fn;
    fn.name = "hartmann6";
    for (int j = 0; j < 6; ++j)
        fn.space.push_back({"x" + std::to_string(j + 1), 0.0, 1.0, false, false});
    fn.minimum = -3.32236801141551;
    fn.f = [](const std::vector<double>& x) {
        static const double alpha[4] = {1.0, 1.2, 3.0, 3.2};
        static const double a[4][6] = {{10, 3, 17, 3.5, 1.7, 8},
                                       {0.05, 10, 17, 0.1, 8, 14},
                                       {3, 3.5, 1.7, 10, 17, 8},
                                       {17, 8, 0.05, 10, 0.1, 14}};
        static const double p[4][6] = {{0.1312, 0.1696, 0.5569, 0.0124, 0.8283, 0.5886},
                                       {0.2329, 0.4135, 0.8307, 0.3736, 0.1004, 0.9991},
                                       {0.2348, 0.1451, 0.3522, 0.2883, 0.3047, 0.6650},
                                       {0.4047, 0.8828, 0.8732, 0.5743, 0.1091, 0.0381}};
        double f = 0.0;
        for (int i = 0; i < 4; ++i) {
            double s = 0.0;
            for (int j = 0; j < 6; ++j) {
                const double dx = x[static_cast<std::size_t>(j)] - p[i][j];
                s += a[i][j] * dx * dx;
            }
            f -= alpha[i] * std::exp(-s);
        }
        return f;
    };
    return fn;
}

TestFunction log_rosenbrock(int dim) {
    TestFunction fn;
    fn.name = "log_rosenbrock" + std::to_string(dim);
    for (int j = 0; j < dim; ++j)
        fn.space.push_back({"x" + std::to_string(j + 1), -2.0, 2.0, false, false});
    fn.minimum = 0.0;
    fn.f = [](const std::vector<double>& x) {
        double f = 0.0;
        for (std::size_t j = 0; j + 1 < x.size(); ++j) {
            const double d = x[j + 1] - x[j] * x[j];
            f += 100.0 * d * d + (1.0 - x[j]) * (1.0 - x[j]);
        }
        return std::log1p(f);
    };
    return fn;
}

namespace {
TestFunction box(const std::string& name, int dim, double low, double high, double minimum,
                 std::function<double(const std::vector<double>&)> f) {
    TestFunction fn;
    fn.name = name + std::to_string(dim);
    for (int j = 0; j < dim; ++j) fn.space.push_back({"x" + std::to_string(j + 1), low, high, false, false});
    fn.minimum = minimum;
    fn.f = std::move(f);
    return fn;
}
}  // namespace

TestFunction rosenbrock(int dim) {
    return box("rosenbrock", dim, -2.0, 2.0, 0.0, [](const std::vector<double>& x) {
        double f = 0.0;
        for (std::size_t j = 0; j + 1 < x.size(); ++j) {
            const double d = x[j + 1] - x[j] * x[j];
            f += 100.0 * d * d + (1.0 - x[j]) * (1.0 - x[j]);
        }
        return f;
    });
}

TestFunction levy(int dim) {
    return box("levy", dim, -10.0, 10.0, 0.0, [](const std::vector<double>& x) {
        const std::size_t d = x.size();
        auto w = [&](std::size_t i) { return 1.0 + (x[i] - 1.0) / 4.0; };
        const double s0 = std::sin(M_PI * w(0));
        double f = s0 * s0;
        for (std::size_t i = 0; i + 1 < d; ++i) {
            const double s = std::sin(M_PI * w(i) + 1.0);
            f += (w(i) - 1.0) * (w(i) - 1.0) * (1.0 + 10.0 * s * s);
        }
        const double sd = std::sin(2.0 * M_PI * w(d - 1));
        return f + (w(d - 1) - 1.0) * (w(d - 1) - 1.0) * (1.0 + sd * sd);
    });
}

TestFunction ackley(int dim) {
    // An asymmetric box: the optimum (0) is not the centre a quasi-random design starts at.
    return box("ackley", dim, -10.0, 30.0, 0.0, [](const std::vector<double>& x) {
        double sq = 0.0, cs = 0.0;
        for (double v : x) {
            sq += v * v;
            cs += std::cos(2.0 * M_PI * v);
        }
        const double n = static_cast<double>(x.size());
        return -20.0 * std::exp(-0.2 * std::sqrt(sq / n)) - std::exp(cs / n) + 20.0 + M_E;
    });
}

TestFunction styblinski_tang(int dim) {
    return box("styblinski_tang", dim, -5.0, 5.0, -39.16616570377142 * dim, [](const std::vector<double>& x) {
        double f = 0.0;
        for (double v : x) f += v * v * v * v - 16.0 * v * v + 5.0 * v;
        return 0.5 * f;
    });
}

TestFunction ellipsoid(int dim) {
    // Axis scales 1 .. 1e3 (condition number 1e6) on a shifted box: ill-conditioned.
    return box("ellipsoid", dim, -3.0, 7.0, 0.0, [](const std::vector<double>& x) {
        const double d = static_cast<double>(x.size());
        double f = 0.0;
        for (std::size_t i = 0; i < x.size(); ++i) {
            const double c = std::pow(10.0, 6.0 * static_cast<double>(i) / std::max(1.0, d - 1.0));
            const double v = x[i] - 1.0;
            f += c * v * v;
        }
        return f;
    });
}

std::vector<std::string> test_function_names() {
    return {"branin", "hartmann6", "branin_integer", "log_rosenbrock9", "rosenbrock9", "levy9",
            "ackley9", "styblinski_tang9", "ellipsoid9"};
}

std::optional<TestFunction> test_function(const std::string& name) {
    if (name == "branin") return branin();
    if (name == "hartmann6") return hartmann6();
    if (name == "branin_integer") return branin_integer();
    if (name == "log_rosenbrock9") return log_rosenbrock(9);
    if (name == "rosenbrock9") return rosenbrock(9);
    if (name == "levy9") return levy(9);
    if (name == "ackley9") return ackley(9);
    if (name == "styblinski_tang9") return styblinski_tang(9);
    if (name == "ellipsoid9") return ellipsoid(9);
    return std::nullopt;
}

}  // namespace maptune::bo
