#pragma once
// The performance measure p of SPEC §2 (thesis §4.2): one number in [0, 1) that rewards
// many matches (v) and accurate ones (eps).

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace maptune::measure {

struct MeasureSettings {
    double e_star = 0.4;  // [m] error at which a match rates 0; must be > 0.05
    double m_star = 60;   // expected number of matches: v(m*) = 0.9; must be > 0
    double w_v = 0.5;     // weight of v; eps gets 1 - w_v; in [0, 1]
};

// Errors of one matched pair.
struct MatchError {
    double e_t = 0;  // [m] ‖t_est − t_ref‖
    double e_r = 0;  // [rad] rotation angle of R_refᵀ·R_est, in [0, π]
    double d = 0;    // [m] submap size: distance from B's origin to its farthest point
};

struct Score {
    double p = 0;       // w_v·v + (1 − w_v)·eps
    double v = 0;       // m / (a + m)
    double eps = 0;     // max(0, mean rating), 0 when m = 0
    std::size_t m = 0;  // matched pairs
    double mean_rating = 0;  // (1/m)·Σ r_i before clamping at 0; 0 when m = 0
};

// v(m) = m / (a + m) with a = m*/9.
double v_of_m(double m, double m_star);
// eps_t(x) = 1 − 2 / (1 + exp(−k·(x − e*))), k = ln 39 / (e* − 0.05).
double eps_t(double x, double e_star);
// Rotation error expressed as the chord it sweeps at distance d: 2·d·sin(e_r / 2).
double rotation_as_translation(double e_r, double d);
// r_i = eps_t(max(e_t, 2·d·sin(e_r/2))): the worse error decides.
double rate_match(const MatchError& error, double e_star);

// Empty string when valid; otherwise which setting is wrong and why.
std::string check_settings(const MeasureSettings& settings);
// Empty string when valid; otherwise the index and field of the first bad value.
std::string check_errors(const std::vector<MatchError>& errors);

// p over the matched pairs' errors. Throws std::invalid_argument on invalid settings or
// errors (NaN, negative): callers validate untrusted input with the check_* functions.
Score score(const std::vector<MatchError>& errors, const MeasureSettings& settings);

// What a subset of n of a view's N pairs says about p on the whole view (multi-fidelity,
// docs/optimizer.md). `ratings` are r_i of the subset's matched pairs; `full` holds the whole
// view's m*. p is the estimate (the subset's match rate scaled to N pairs, its mean rating):
// exactly the subset's p with m* scaled by n/N. p_upper bounds p on the whole view at z
// standard errors: a Wilson upper bound on the match rate and a mean rating z standard errors
// up (each with the finite-population correction, so n = N gives p_upper = p; fewer than two
// matches leave the rating unbounded: the best a match can rate).
struct Extrapolation {
    double p = 0, v = 0, eps = 0;  // the estimate and its parts
    double p_upper = 0;
};
Extrapolation extrapolate(const std::vector<double>& ratings, std::size_t n, std::size_t N,
                          const MeasureSettings& full, double z);

// Multi-fidelity's paired rule (docs/optimizer.md): a proposal x and the incumbent on the same
// n of a view's N pairs, one outcome per pair (NaN: not matched; else its rating r_i). Their
// p on the subset (m* scaled by n/N), each times its factor (the run-time penalty), differ by
// `difference`; `upper` is that difference z bootstrap standard errors up (pairs resampled,
// the same resample for both, a fixed seed; finite-population correction). x can still beat
// the incumbent on the whole view when upper >= 0. Pairs the two matched alike cancel, so a
// set that matches nothing where the incumbent matches is told apart on a few dozen pairs.
struct PairedDifference {
    double difference = 0, upper = 0;
};
PairedDifference paired_difference(const std::vector<double>& x, const std::vector<double>& incumbent,
                                   std::size_t N, const MeasureSettings& full, double z, double factor_x = 1,
                                   double factor_incumbent = 1);

// Errors of an estimate against a reference, both the pose of B in A's frame.
MatchError pair_error(const Eigen::Isometry3d& T_a_b_ref, const Eigen::Isometry3d& T_a_b_est,
                      double d);
// Rotation angle of a rotation matrix in [0, π], accurate for small and near-π angles.
double rotation_angle(const Eigen::Matrix3d& R);

}  // namespace maptune::measure
