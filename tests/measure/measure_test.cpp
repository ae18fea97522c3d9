#include "measure/measure.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace maptune::measure {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(Measure, CheckValuesOfSpec) {
    // SPEC §2 check values for e* = 0.4.
    EXPECT_NEAR(std::log(39.0) / (0.4 - 0.05), 10.4673, 1e-4);
    EXPECT_NEAR(eps_t(0.0, 0.4), 0.97007, 1e-5);
    EXPECT_NEAR(eps_t(0.05, 0.4), 0.95, 1e-12);
    EXPECT_NEAR(eps_t(0.2, 0.4), 0.78053, 1e-5);
    EXPECT_NEAR(eps_t(0.4, 0.4), 0.0, 1e-12);
    EXPECT_NEAR(eps_t(1.0, 0.4), -0.99626, 1e-5);
    EXPECT_NEAR(60.0 / 9.0, 6.667, 1e-3);
    EXPECT_NEAR(v_of_m(60, 60), 0.9, 1e-12);
    EXPECT_NEAR(v_of_m(0, 60), 0.0, 1e-12);
}

TEST(Measure, WorseErrorDecides) {
    // Rotation of 0.1 rad at d = 5 m sweeps 2·5·sin(0.05) = 0.49979 m: worse than e_t = 0.1.
    const MatchError e{0.1, 0.1, 5.0};
    EXPECT_NEAR(rotation_as_translation(0.1, 5.0), 0.499791692, 1e-9);
    EXPECT_NEAR(rate_match(e, 0.4), eps_t(rotation_as_translation(0.1, 5.0), 0.4), 1e-12);
    // With a small submap the translation error decides.
    const MatchError small{0.1, 0.1, 0.2};
    EXPECT_NEAR(rate_match(small, 0.4), eps_t(0.1, 0.4), 1e-12);
}

TEST(Measure, ScoreCombinesVAndEps) {
    MeasureSettings s;  // e* 0.4, m* 60, w_v 0.5
    std::vector<MatchError> errors(60, MatchError{0.05, 0.0, 3.0});
    const Score sc = score(errors, s);
    EXPECT_EQ(sc.m, 60u);
    EXPECT_NEAR(sc.v, 0.9, 1e-12);
    EXPECT_NEAR(sc.eps, 0.95, 1e-12);
    EXPECT_NEAR(sc.p, 0.5 * 0.9 + 0.5 * 0.95, 1e-12);
    s.w_v = 0.25;
    EXPECT_NEAR(score(errors, s).p, 0.25 * 0.9 + 0.75 * 0.95, 1e-12);
}

TEST(Measure, NoMatchesNeverScoresWell) {
    const Score sc = score({}, MeasureSettings{});
    EXPECT_EQ(sc.m, 0u);
    EXPECT_EQ(sc.p, 0.0);
    EXPECT_EQ(sc.eps, 0.0);
    EXPECT_EQ(sc.v, 0.0);
}

TEST(Measure, HugeErrorsClampEpsAtZeroButKeepV) {
    std::vector<MatchError> errors(10, MatchError{1e6, kPi, 1e3});
    const Score sc = score(errors, MeasureSettings{0.4, 60, 0.5});
    EXPECT_NEAR(sc.mean_rating, -1.0, 1e-9);
    EXPECT_EQ(sc.eps, 0.0);
    EXPECT_NEAR(sc.v, 10.0 / (60.0 / 9.0 + 10.0), 1e-12);
    EXPECT_NEAR(sc.p, 0.5 * sc.v, 1e-12);
    EXPECT_LT(sc.p, 1.0);
}

TEST(Measure, PIsBelowOneEvenForPerfectMatches) {
    std::vector<MatchError> errors(100000, MatchError{0, 0, 1});
    const Score sc = score(errors, MeasureSettings{});
    EXPECT_GT(sc.p, 0.95);
    EXPECT_LT(sc.p, 1.0);
}

TEST(Measure, RejectsNaNAndInvalidSettings) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(score({MatchError{nan, 0, 1}}, MeasureSettings{}), std::invalid_argument);
    EXPECT_THROW(score({MatchError{0, nan, 1}}, MeasureSettings{}), std::invalid_argument);
    EXPECT_THROW(score({MatchError{0, 0, -1}}, MeasureSettings{}), std::invalid_argument);
    EXPECT_EQ(check_errors({MatchError{}, MatchError{0, nan, 1}}), "matches[1].e_r must be a finite number >= 0");
    EXPECT_THROW(score({}, MeasureSettings{0.05, 60, 0.5}), std::invalid_argument);
    EXPECT_THROW(score({}, MeasureSettings{0.4, 0, 0.5}), std::invalid_argument);
    EXPECT_THROW(score({}, MeasureSettings{0.4, 60, 1.5}), std::invalid_argument);
    EXPECT_THROW(score({}, MeasureSettings{nan, 60, 0.5}), std::invalid_argument);
}

TEST(PairError, FromTransforms) {
    Eigen::Isometry3d ref = Eigen::Isometry3d::Identity();
    ref.translate(Eigen::Vector3d(1, 2, 3));
    ref.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
    Eigen::Isometry3d est = ref;
    est.translation() += Eigen::Vector3d(0.03, -0.04, 0);
    est.rotate(Eigen::AngleAxisd(0.02, Eigen::Vector3d(1, 1, 0).normalized()));
    const MatchError e = pair_error(ref, est, 4.0);
    EXPECT_NEAR(e.e_t, 0.05, 1e-12);
    EXPECT_NEAR(e.e_r, 0.02, 1e-12);
    EXPECT_EQ(e.d, 4.0);
}

TEST(PairError, RotationAngleIsAccurateAtTinyAndNearPiAngles) {
    for (double angle : {1e-9, 1e-5, 0.5, 3.0, kPi - 1e-7}) {
        const Eigen::Matrix3d R =
            Eigen::AngleAxisd(angle, Eigen::Vector3d(0.2, -0.5, 0.8).normalized()).toRotationMatrix();
        EXPECT_NEAR(rotation_angle(R), angle, 1e-9 * std::max(1.0, angle)) << angle;
    }
}

}  // namespace
}  // namespace maptune::measure

namespace maptune::measure {
namespace {

// Multi-fidelity (issue 16 item 2): a subset's estimate is its own p with m* scaled, the bound
// is above it, tightens with more pairs and is the estimate once the subset is the view.
TEST(Extrapolate, EstimateIsTheSubsetsPWithScaledMStarAndTheBoundIsAboveIt) {
    const MeasureSettings full{0.4, 480, 0.5};
    std::vector<MatchError> errors;
    std::vector<double> ratings;
    for (int i = 0; i < 150; ++i) {
        errors.push_back({0.02 + 0.003 * (i % 50), 0.001, 10});
        ratings.push_back(rate_match(errors.back(), full.e_star));
    }
    const Score subset = score(errors, {0.4, 480.0 * 195 / 1560, 0.5});
    const Extrapolation x = extrapolate(ratings, 195, 1560, full, 2);
    EXPECT_NEAR(x.p, subset.p, 1e-12);
    EXPECT_NEAR(x.v, subset.v, 1e-12);
    EXPECT_NEAR(x.eps, subset.eps, 1e-12);
    EXPECT_GT(x.p_upper, x.p);
    EXPECT_LT(x.p_upper, x.p + 0.1);
    EXPECT_DOUBLE_EQ(extrapolate(ratings, 195, 1560, full, 0).p_upper, x.p);

    const Extrapolation whole = extrapolate(ratings, 1560, 1560, full, 2);
    EXPECT_DOUBLE_EQ(whole.p_upper, whole.p);
    // Four times the pairs (the same rate and ratings): a tighter bound.
    std::vector<double> more;
    for (int i = 0; i < 4; ++i) more.insert(more.end(), ratings.begin(), ratings.end());
    EXPECT_LT(extrapolate(more, 780, 1560, full, 2).p_upper - x.p, x.p_upper - x.p);
}

TEST(Extrapolate, NoMatchesBoundOnlyWhatTheMatchRateAllows) {
    const MeasureSettings full{0.4, 480, 0.5};
    const Extrapolation none = extrapolate({}, 195, 1560, full, 2);
    EXPECT_DOUBLE_EQ(none.p, 0.0);
    // Unknown ratings may be the best, but at most ~z²/n of the pairs can match.
    EXPECT_GT(none.p_upper, 0.0);
    EXPECT_LT(none.p_upper, 0.5 * v_of_m(0.03 * 1560, 480) + 0.5 * eps_t(0, 0.4));
    EXPECT_THROW(extrapolate({0.5}, 0, 10, full, 2), std::invalid_argument);
    EXPECT_THROW(extrapolate({0.5, 0.5}, 1, 10, full, 2), std::invalid_argument);
    EXPECT_THROW(extrapolate({}, 11, 10, full, 2), std::invalid_argument);
}


TEST(PairedDifference, PairsMatchedAlikeCancelAndNothingWhereTheBestMatchesIsToldApart) {
    const MeasureSettings full{0.4, 480, 0.5};
    const double no = std::nan("");
    std::vector<double> best, same, none, better;
    for (int i = 0; i < 50; ++i) {
        const bool matched = i % 5 != 0;  // 40 of 50
        best.push_back(matched ? 0.8 : no);
        same.push_back(best.back());
        none.push_back(no);
        better.push_back(0.9);
    }
    const auto tie = paired_difference(same, best, 1560, full, 2);
    EXPECT_DOUBLE_EQ(tie.difference, 0.0);
    EXPECT_DOUBLE_EQ(tie.upper, 0.0) << "identical outcomes: every resample agrees";
    const auto hopeless = paired_difference(none, best, 1560, full, 2);
    EXPECT_LT(hopeless.upper, 0.0);
    EXPECT_LT(hopeless.difference, hopeless.upper);
    const auto up = paired_difference(better, best, 1560, full, 2);
    EXPECT_GT(up.difference, 0.0);
    // The same pairs as the whole view: no sampling error left.
    const auto whole = paired_difference(none, best, 50, full, 2);
    EXPECT_DOUBLE_EQ(whole.upper, whole.difference);
    // A run-time penalty on the incumbent counts: the same outcomes at a quarter of its p lose.
    EXPECT_GT(paired_difference(same, best, 1560, full, 2, 1.0, 0.25).difference, 0.0);
    // Deterministic: the same answers, the same decision.
    EXPECT_DOUBLE_EQ(paired_difference(better, best, 1560, full, 2).upper, up.upper);
    EXPECT_THROW(paired_difference(same, {0.5}, 1560, full, 2), std::invalid_argument);
    EXPECT_THROW(paired_difference(same, best, 10, full, 2), std::invalid_argument);
}

}  // namespace
}  // namespace maptune::measure
