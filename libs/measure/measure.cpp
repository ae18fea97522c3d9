#include "measure/measure.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace maptune::measure {

namespace {

// p from v and the mean rating: eps is the mean rating clamped at 0 (SPEC §2).
double combine(double v, double mean_rating, double w_v) { return w_v * v + (1.0 - w_v) * std::max(0.0, mean_rating); }

// p of outcomes (NaN: no match) over the pairs `index` picks; m* already scaled to them.
template <class Index>
double p_of_outcomes(const std::vector<double>& outcomes, const Index& index, std::size_t n, double m_star,
                     double w_v) {
    double m = 0, sum = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const double r = outcomes[index(i)];
        if (std::isnan(r)) continue;
        m += 1;
        sum += r;
    }
    return combine(v_of_m(m, m_star), m > 0 ? sum / m : 0.0, w_v);
}

}  // namespace

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
    s.p = combine(s.v, s.eps, settings.w_v);
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

Extrapolation extrapolate(const std::vector<double>& ratings, std::size_t n, std::size_t N,
                          const MeasureSettings& full, double z) {
    if (n == 0 || N < n || ratings.size() > n || !(z >= 0)) {
        throw std::invalid_argument("extrapolate: need 0 < n <= N, matches <= n and z >= 0");
    }
    const double nn = static_cast<double>(n), NN = static_cast<double>(N);
    const double m = static_cast<double>(ratings.size());
    // Sampling without replacement: the spread shrinks to 0 as the subset becomes the view.
    const double fpc = N > 1 ? std::sqrt((NN - nn) / (NN - 1)) : 0.0;
    const double q = m / nn;
    const double z2 = z * z;
    const double wilson =
        (q + z2 / (2 * nn) + z * std::sqrt(q * (1 - q) / nn + z2 / (4 * nn * nn))) / (1 + z2 / nn);
    const double q_upper = std::min(1.0, q + (wilson - q) * fpc);

    double mean = 0;
    for (const double r : ratings) mean += r;
    mean = ratings.empty() ? 0.0 : mean / m;
    const double best_rating = eps_t(0, full.e_star);
    double mean_upper = best_rating;
    if (ratings.size() >= 2) {
        double ss = 0;
        for (const double r : ratings) ss += (r - mean) * (r - mean);
        const double sd = std::sqrt(ss / (m - 1));
        // The whole view's matches are about q·N; the subset's m of them are known.
        const double matches = std::max(m, q * NN);
        const double fpc_m = matches > 1 ? std::sqrt(std::max(0.0, (matches - m) / (matches - 1))) : 0.0;
        mean_upper = std::min(best_rating, mean + z * sd / std::sqrt(m) * fpc_m);
    } else if (fpc == 0) {
        mean_upper = mean;
    }
    const double w = full.w_v;
    Extrapolation out;
    out.v = v_of_m(q * NN, full.m_star);
    out.eps = std::max(0.0, mean);
    out.p = combine(out.v, mean, w);
    out.p_upper = std::max(out.p, combine(v_of_m(q_upper * NN, full.m_star), mean_upper, w));
    return out;
}

PairedDifference paired_difference(const std::vector<double>& x, const std::vector<double>& incumbent,
                                   std::size_t N, const MeasureSettings& full, double z, double factor_x,
                                   double factor_incumbent) {
    const std::size_t n = x.size();
    if (n == 0 || incumbent.size() != n || N < n || !(z >= 0)) {
        throw std::invalid_argument("paired_difference: need outcomes of the same 0 < n <= N pairs and z >= 0");
    }
    const double m_star = full.m_star * static_cast<double>(n) / static_cast<double>(N);
    auto diff = [&](const auto& index) {
        return factor_x * p_of_outcomes(x, index, n, m_star, full.w_v) -
               factor_incumbent * p_of_outcomes(incumbent, index, n, m_star, full.w_v);
    };
    PairedDifference out;
    out.difference = diff([](std::size_t i) { return i; });
    const double fpc = N > 1 ? std::sqrt(static_cast<double>(N - n) / static_cast<double>(N - 1)) : 0.0;
    if (fpc == 0 || z == 0) {
        out.upper = out.difference;
        return out;
    }
    // A fixed seed: the same answers give the same decision (a resumed run decides alike).
    std::mt19937_64 rng(0x6d6170747566ULL);
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);
    constexpr int kResamples = 400;
    std::vector<std::size_t> sample(n);
    double mean = 0, sq = 0;
    for (int b = 0; b < kResamples; ++b) {
        for (auto& s : sample) s = pick(rng);
        const double d = diff([&](std::size_t i) { return sample[i]; });
        mean += d;
        sq += d * d;
    }
    mean /= kResamples;
    const double sd = std::sqrt(std::max(0.0, sq / kResamples - mean * mean));
    out.upper = out.difference + z * sd * fpc;
    return out;
}

}  // namespace maptune::measure
