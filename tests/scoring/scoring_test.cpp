#include "scoring/scoring.hpp"

#include <gtest/gtest.h>

#include <filesystem>

#include "dataset/simulator.hpp"
#include "temp_dataset.hpp"

namespace maptune::scoring {
namespace {

namespace fs = std::filesystem;

class ScoringTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        root_ = test::make_temp_dir("maptune_scoring_test_");
        test::generate_tiny_dataset(root_, "ds", 2, 4);
    }
    static void TearDownTestSuite() { fs::remove_all(root_); }
    static fs::path root_;
};
fs::path ScoringTest::root_;

// Estimates equal to the reference for the first `exact` pairs, off by `offset` metres for
// the rest; every pair matched.
std::vector<store::PairRecord> results(const std::vector<dataset::SubmapPair>& pairs, std::size_t exact,
                                       double offset) {
    std::vector<store::PairRecord> out;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        store::PairRecord r;
        r.pair_id = pair_id(pairs[i]);
        r.matched = true;
        Eigen::Isometry3d T = pairs[i].T_a_b;
        if (i >= exact) T.translation().x() += offset;
        r.T_a_b_est = T.matrix();
        out.push_back(r);
    }
    return out;
}

TEST(PairIdTest, SplitsWhatPairIdJoinsAndRefusesTheRest) {
    dataset::SubmapPair p;
    p.id_a = "run00/submap003";
    p.id_b = "run00/submap004";
    EXPECT_EQ(split_pair_id(pair_id(p)), std::make_optional(std::make_pair(p.id_a, p.id_b)));
    for (const std::string bad : {"run00/submap003", "|run00/submap004", "run00/submap003|", ""})
        EXPECT_FALSE(split_pair_id(bad).has_value()) << bad;
}

TEST_F(ScoringTest, ExactEstimatesScoreTheMeasureOfZeroError) {
    const auto ds = dataset::Dataset::open(root_ / "ds");
    const auto pairs = ds.pairs(dataset::View::subsequent, dataset::Reference::gt);
    ASSERT_EQ(pairs.size(), 6u);  // 2 runs x 3 subsequent pairs
    const measure::MeasureSettings s{0.4, 6, 0.5};
    const auto report = score_observation(ds, pairs, results(pairs, pairs.size(), 0), s);
    EXPECT_EQ(report.matched, 6u);
    EXPECT_EQ(report.missing, 0u);
    EXPECT_NEAR(report.e_t.max, 0, 1e-9);
    EXPECT_NEAR(report.score.eps, measure::eps_t(0, 0.4), 1e-6);
    EXPECT_NEAR(report.score.p, 0.5 * 0.9 + 0.5 * measure::eps_t(0, 0.4), 1e-6);
    for (const auto& p : report.per_pair) {
        EXPECT_GT(p.d, 0) << "submap size of B comes from the dataset";
    }
}

TEST_F(ScoringTest, ErrorsAreMeasuredAgainstTheChosenReference) {
    const auto ds = dataset::Dataset::open(root_ / "ds");
    const auto gt = ds.pairs(dataset::View::subsequent, dataset::Reference::gt);
    const auto odom = ds.pairs(dataset::View::subsequent, dataset::Reference::odometry);
    const auto est = results(gt, 3, 0.25);  // estimates: gt exact for 3 pairs, 25 cm off for 3
    const measure::MeasureSettings s{0.4, 6, 0.5};
    const auto vs_gt = score_observation(ds, gt, est, s);
    EXPECT_NEAR(vs_gt.e_t.max, 0.25, 1e-9);
    EXPECT_NEAR(vs_gt.e_t.median, 0.25, 1e-9);  // sorted: 0 0 0 .25 .25 .25, median index 3
    // Against odometry the same estimates carry the odometry's drift as error.
    const auto vs_odom = score_observation(ds, odom, est, s);
    EXPECT_GT(vs_odom.e_t.mean, 0.0);
    EXPECT_NE(vs_odom.score.p, vs_gt.score.p);
}

TEST_F(ScoringTest, UnmatchedFailedAndMissingPairs) {
    const auto ds = dataset::Dataset::open(root_ / "ds");
    const auto pairs = ds.pairs(dataset::View::complete, dataset::Reference::gt);
    ASSERT_EQ(pairs.size(), 12u);  // 2 runs x C(4,2)
    auto est = results(pairs, pairs.size(), 0);
    est[0].matched = false;
    est[0].status = store::PairStatus::kNoMatch;
    est[1].matched = false;
    est[1].status = store::PairStatus::kFailed;
    est[2].matched = false;
    est[2].status = store::PairStatus::kTimeout;
    est.pop_back();  // no result for the last pair
    const auto r = score_observation(ds, pairs, est, {0.4, 12, 0.5});
    EXPECT_EQ(r.matched, 8u);
    EXPECT_EQ(r.failed, 1u);
    EXPECT_EQ(r.timeouts, 1u);
    EXPECT_EQ(r.missing, 1u);
    EXPECT_EQ(r.per_pair.size(), 12u);
}

// Two parts of a view scored apart and pooled with the sum of their m* give what the whole
// view scores: the same p, counts and error statistics.
TEST_F(ScoringTest, PoolingPartsOfAViewScoresTheWholeView) {
    const auto ds = dataset::Dataset::open(root_ / "ds");
    const auto pairs = ds.pairs(dataset::View::complete, dataset::Reference::gt);
    ASSERT_EQ(pairs.size(), 12u);
    auto est = results(pairs, 4, 0.3);  // 4 exact, 8 off by 30 cm
    est[5].matched = false;
    est[5].status = store::PairStatus::kNoMatch;
    est[9].matched = false;
    est[9].status = store::PairStatus::kFailed;
    for (std::size_t i = 0; i < est.size(); ++i) est[i].duration_s = 0.1 * static_cast<double>(i + 1);
    const std::vector<dataset::SubmapPair> first(pairs.begin(), pairs.begin() + 5), rest(pairs.begin() + 5, pairs.end());
    const measure::MeasureSettings s1{0.4, 2, 0.5}, s2{0.4, 5, 0.5}, all{0.4, 7, 0.5};
    const auto a = score_observation(ds, first, est, s1);
    const auto b = score_observation(ds, rest, est, s2);
    const auto whole = score_observation(ds, pairs, est, all);
    const auto pooled = pool_reports({&a, &b}, all);
    EXPECT_NEAR(pooled.score.p, whole.score.p, 1e-12);
    EXPECT_NEAR(pooled.score.eps, whole.score.eps, 1e-12);
    EXPECT_EQ(pooled.score.m, whole.score.m);
    EXPECT_EQ(pooled.score.m, 10u);
    EXPECT_EQ(pooled.pairs, 12u);
    EXPECT_EQ(pooled.matched, whole.matched);
    EXPECT_EQ(pooled.failed, 1u);
    EXPECT_EQ(pooled.per_pair.size(), 12u);
    EXPECT_NEAR(pooled.e_t.median, whole.e_t.median, 1e-12);
    EXPECT_NEAR(pooled.e_r.p90, whole.e_r.p90, 1e-12);
    EXPECT_NEAR(pooled.mean_pair_s, whole.mean_pair_s, 1e-12);
    // Not the mean of the parts' p: m* and the ratings are pooled, not the scores.
    EXPECT_NE(pooled.score.p, 0.5 * (a.score.p + b.score.p));
}

TEST_F(ScoringTest, MStarIsDerivedFromOverlappingPairs) {
    const auto ds = dataset::Dataset::open(root_ / "ds");
    const auto pairs = ds.pairs(dataset::View::complete, dataset::Reference::gt);
    std::size_t n = 0;
    for (const auto& p : pairs) n += p.overlap >= 0.3 ? 1 : 0;
    EXPECT_EQ(derive_m_star(pairs), static_cast<double>(std::max<std::size_t>(n, 1)));
    EXPECT_EQ(derive_m_star(std::vector<dataset::SubmapPair>{}), 1.0);
    EXPECT_EQ(derive_m_star(std::vector<double>{0.1, 0.3, 0.9, 0.29}), 2.0);
    EXPECT_EQ(derive_m_star(std::vector<double>{0.1, 0.3, 0.9}, 0.05), 3.0);
}

}  // namespace
}  // namespace maptune::scoring
