#pragma once
// Standard optimization test functions (to be minimized) for tests and benchmarks.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "bo/space.hpp"

namespace maptune::bo {

struct TestFunction {
    std::string name;
    std::vector<ParameterSpec> space;
    double minimum = 0.0;  // global minimum value
    std::function<double(const std::vector<double>&)> f;
};

TestFunction branin();                 // 2-D, x1 in [-5, 10], x2 in [0, 15], min 0.397887
TestFunction hartmann6();              // 6-D unit cube, min -3.32237
TestFunction log_rosenbrock(int dim);  // log(1 + Rosenbrock) on [-2, 2]^d, min 0
// 9-D benchmark functions of other kinds (issue 15): values over orders of magnitude
// (rosenbrock: 0 .. 1e5), multi-modal (levy, ackley on an off-centre box, styblinski_tang),
// ill-conditioned (ellipsoid: axis scales 1 .. 1e3).
TestFunction rosenbrock(int dim);       // [-2, 2]^d, min 0 at 1
TestFunction levy(int dim);             // [-10, 10]^d, min 0 at 1
TestFunction ackley(int dim);           // [-10, 30]^d, min 0 at 0
TestFunction styblinski_tang(int dim);  // [-5, 5]^d, min -39.166 d at -2.9035
TestFunction ellipsoid(int dim);        // [-3, 7]^d, min 0 at 1
// Branin with x2 restricted to integers 0..15: checks integer handling (min 0.397887 is not
// reachable exactly; the best integer x2 gives the reported minimum).
TestFunction branin_integer();
std::optional<TestFunction> test_function(const std::string& name);
std::vector<std::string> test_function_names();

}  // namespace maptune::bo
