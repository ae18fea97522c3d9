#include "bo/space.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace maptune::bo {

SearchSpace::SearchSpace(std::vector<ParameterSpec> specs) : specs_(std::move(specs)) {
    if (specs_.empty()) throw std::invalid_argument("SearchSpace: no parameters");
    for (ParameterSpec& s : specs_) {
        if (s.is_integer) {
            s.low = std::ceil(s.low);
            s.high = std::floor(s.high);
        }
        if (s.is_integer || !(s.step > 0.0) || !std::isfinite(s.step)) s.step = 0.0;
        if (!(s.high >= s.low))
            throw std::invalid_argument("SearchSpace: high < low for " + s.name);
        if (s.log_scale && (s.low <= 0.0 || (s.is_integer && s.low < 1.0))) {
            throw std::invalid_argument("SearchSpace: log scale needs a positive low for " +
                                        s.name);
        }
    }
}

bool SearchSpace::has_integers() const {
    return std::any_of(specs_.begin(), specs_.end(), [](const auto& s) { return s.is_integer; });
}

bool SearchSpace::has_grid() const {
    return std::any_of(specs_.begin(), specs_.end(), [](const auto& s) { return s.is_integer || s.step > 0.0; });
}

double SearchSpace::grid_value(int j, double x) const {
    const ParameterSpec& s = specs_[static_cast<std::size_t>(j)];
    const double first = std::ceil(s.low / s.step - 1e-9), last = std::floor(s.high / s.step + 1e-9);
    if (first > last) return x;  // no grid point inside the bounds
    return std::clamp(std::round(x / s.step), first, last) * s.step;
}

double SearchSpace::transform(int j, double x) const {
    return specs_[static_cast<std::size_t>(j)].log_scale ? std::log(x) : x;
}

double SearchSpace::inverse_transform(int j, double t) const {
    return specs_[static_cast<std::size_t>(j)].log_scale ? std::exp(t) : t;
}

double SearchSpace::integer_value(int j, double u) const {
    // Equal-width bins in (transformed) u so every integer is equally likely under uniform u.
    const ParameterSpec& s = specs_[static_cast<std::size_t>(j)];
    const double lo = transform(j, s.low - 0.5);
    const double hi = transform(j, s.high + 0.5);
    const double x = std::round(inverse_transform(j, lo + std::clamp(u, 0.0, 1.0) * (hi - lo)));
    return std::clamp(x, s.low, s.high);
}

std::vector<double> SearchSpace::to_values(const Eigen::VectorXd& u) const {
    std::vector<double> values(specs_.size());
    for (int j = 0; j < dim(); ++j) {
        const ParameterSpec& s = specs_[static_cast<std::size_t>(j)];
        if (s.is_integer) {
            values[static_cast<std::size_t>(j)] = integer_value(j, u(j));
        } else {
            const double lo = transform(j, s.low);
            const double hi = transform(j, s.high);
            const double x = inverse_transform(j, lo + std::clamp(u(j), 0.0, 1.0) * (hi - lo));
            values[static_cast<std::size_t>(j)] = s.step > 0.0 ? grid_value(j, x) : std::clamp(x, s.low, s.high);
        }
    }
    return values;
}

Eigen::VectorXd SearchSpace::from_values(const std::vector<double>& values) const {
    if (values.size() != specs_.size()) throw std::invalid_argument("SearchSpace: wrong size");
    Eigen::VectorXd u(dim());
    for (int j = 0; j < dim(); ++j) {
        const ParameterSpec& s = specs_[static_cast<std::size_t>(j)];
        const double x = std::clamp(values[static_cast<std::size_t>(j)], s.low, s.high);
        double lo = 0.0, hi = 0.0;
        if (s.is_integer) {
            lo = transform(j, s.low - 0.5);
            hi = transform(j, s.high + 0.5);
        } else {
            lo = transform(j, s.low);
            hi = transform(j, s.high);
        }
        const double xr = s.is_integer ? std::round(x) : x;
        u(j) = hi > lo ? std::clamp((transform(j, xr) - lo) / (hi - lo), 0.0, 1.0) : 0.5;
    }
    return u;
}

Eigen::VectorXd SearchSpace::to_model_input(const Eigen::VectorXd& u) const {
    Eigen::VectorXd g = u.cwiseMax(0.0).cwiseMin(1.0);
    for (int j = 0; j < dim(); ++j) {
        const ParameterSpec& s = specs_[static_cast<std::size_t>(j)];
        if (!s.is_integer) continue;
        const double lo = transform(j, s.low);
        const double hi = transform(j, s.high);
        g(j) = hi > lo ? (transform(j, integer_value(j, u(j))) - lo) / (hi - lo) : 0.5;
    }
    return g;
}

Eigen::VectorXd SearchSpace::snap(const Eigen::VectorXd& u) const {
    if (!has_grid()) return u.cwiseMax(0.0).cwiseMin(1.0);
    return from_values(to_values(u));
}

std::vector<double> SearchSpace::canonical(const std::vector<double>& values) const {
    return to_values(from_values(values));
}

}  // namespace maptune::bo
