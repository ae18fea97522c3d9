#include "measure/measure.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace maptune::measure {

double v_of_m(double m, double m_star) {
    const double a = m_star / 9.0;
    return m / (a + m);
}

double eps_t(double x, double e_star) {
    const double k = std::log(39.0) / (e_star - 0.05);
    return 1.0 - 2.0 / (1.0 + std::exp(-k * (x - e_star)));
}

double rotation_as_translation(double e_r, double d) { return 2.0 * d * std::sin(e_r / 2.0); }

double rate_match(const MatchError& error, double e_star) {
    return eps_t(std::max(error.e_t, rotation_as_translation(error.e_r, error.d)), e_star);
}

std::string check_settings(const MeasureSettings& s) {
    if (!std::isfinite(s.e_star) || s.e_star <= 0.05) {
        return "e_star must be a finite number > 0.05 m (eps_t(0.05) = 0.95 fixes the slope)";
    }
    if (!std::isfinite(s.m_star) || s.m_star <= 0) return "m_star must be a finite number > 0";
    if (!std::isfinite(s.w_v) || s.w_v < 0 || s.w_v > 1) return "w_v must be in [0, 1]";
    return "";
}

std::string check_errors(const std::vector<MatchError>& errors) {
    for (std::size_t i = 0; i < errors.size(); ++i) {
        const auto& e = errors[i];
        const std::string at = "matches[" + std::to_string(i) + "].";
        if (!std::isfinite(e.e_t) || e.e_t < 0) return at + "e_t must be a finite number >= 0";
        if (!std::isfinite(e.e_r) || e.e_r < 0) return at + "e_r must be a finite number >= 0";
        if (!std::isfinite(e.d) || e.d < 0) return at + "d must be a finite number >= 0";
    }
    return "";
}

Score score(const std::vector<MatchError>& errors, const MeasureSettings& settings) {
    if (auto bad = check_settings(settings); !bad.empty()) throw std::invalid_argument(bad);
    if (auto bad = check_errors(errors); !bad.empty()) throw std::invalid_argument(bad);
    Score s;
    s.m = errors.size();
    s.v = v_of_m(static_cast<double>(s.m), settings.m_star);
    if (s.m > 0) {
        double sum = 0;
        for (const auto& e : errors) sum += rate_match(e, settings.e_star);
        s.mean_rating = sum / static_cast<double>(s.m);
        s.eps = std::max(0.0, s.mean_rating);
    }
    s.p = settings.w_v * s.v + (1.0 - settings.w_v) * s.eps;
    return s;
}

double rotation_angle(const Eigen::Matrix3d& R) {
    // atan2 of sin and cos of the angle keeps precision where acos((tr − 1)/2) loses it.
    const Eigen::Vector3d axis_sin(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
    const double sin_angle = 0.5 * axis_sin.norm();
    const double cos_angle = 0.5 * (R.trace() - 1.0);
    return std::atan2(sin_angle, cos_angle);
}

MatchError pair_error(const Eigen::Isometry3d& T_a_b_ref, const Eigen::Isometry3d& T_a_b_est,
                      double d) {
    MatchError e;
    e.e_t = (T_a_b_est.translation() - T_a_b_ref.translation()).norm();
    e.e_r = rotation_angle(T_a_b_ref.rotation().transpose() * T_a_b_est.rotation());
    e.d = d;
    return e;
}

}  // namespace maptune::measure
