// The FPFH + RANSAC + GICP plug-in's matcher on real scans shipped with the tests (the Stanford
// bunny with its bun.conf ground truth) and its parameter checks.
#include <gtest/gtest.h>

#include <algorithm>

#include "fpfh_matcher.hpp"
#include "matcher/cloud_io.hpp"
#include "measure/measure.hpp"

namespace maptune::fpfh {
namespace {

const std::string kBunnyDir = MAPTUNE_SOURCE_DIR "/tests/data/stanford_bunny/";

// The hand-tuned set (configs/plugins/fpfh_gicp_hand.yaml: the defaults) at the bunny's scale:
// its radii are in voxels, so 2 mm voxels are the only change.
Params bunny_params() {
    Params p;
    p.voxel_m = 0.002;
    return p;
}

std::vector<Eigen::Vector3f> scan(const std::string& name) {
    auto v = matcher::io::read_xyz(kBunnyDir + name);
    v.erase(std::remove_if(v.begin(), v.end(), [](const auto& p) { return p.squaredNorm() == 0; }), v.end());
    return v;
}

struct BunnyCase {
    std::string target, source;
};

class FpfhBunnyPair : public ::testing::TestWithParam<BunnyCase> {};

TEST_P(FpfhBunnyPair, RegistersWithinTwoDegreesAndTwoPercent) {
    const auto& c = GetParam();
    const auto poses = matcher::io::read_bunny_conf(kBunnyDir + "bun.conf");
    ASSERT_TRUE(poses.count(c.target) && poses.count(c.source));
    const Eigen::Matrix4d T_ref = (poses.at(c.target).inverse() * poses.at(c.source)).matrix();
    const auto a = prepare(scan(c.target), bunny_params());
    const auto b = prepare(scan(c.source), bunny_params());
    ASSERT_TRUE(a.cloud) << a.reason;
    ASSERT_TRUE(b.cloud) << b.reason;
    const auto r = register_pair(*a.cloud, *b.cloud, bunny_params(), Settings{}, 1);
    ASSERT_TRUE(r.matched) << r.reason;
    const auto e = measure::pair_error(Eigen::Isometry3d(T_ref), Eigen::Isometry3d(r.T_a_b), 0);
    EXPECT_LT(e.e_r * 180.0 / M_PI, 2.0);
    EXPECT_LT(e.e_t, 0.02 * 0.15);
    EXPECT_GT(r.overlap, 0.5);
    // Same input, same seed: the same transform (tasks are replayed after faults).
    const auto again = register_pair(*a.cloud, *b.cloud, bunny_params(), Settings{}, 1);
    EXPECT_TRUE(again.T_a_b.isApprox(r.T_a_b));
}

INSTANTIATE_TEST_SUITE_P(Scans, FpfhBunnyPair,
                         ::testing::Values(BunnyCase{"bun000.ply", "bun045.ply"},
                                           BunnyCase{"bun000.ply", "bun315.ply"},
                                           BunnyCase{"bun045.ply", "bun090.ply"}),
                         [](const auto& tp) {
                             auto strip = [](std::string s) { return s.substr(0, s.find('.')); };
                             return strip(tp.param.target) + "_" + strip(tp.param.source);
                         });

TEST(FpfhMatcher, TheOverlapDecisionRejectsAPoorRegistration) {
    // A wrong registration leaves little of B on A: demand more overlap than any pose gives.
    auto p = bunny_params();
    const auto a = prepare(scan("bun000.ply"), p);
    const auto b = prepare(scan("bun090.ply"), p);
    ASSERT_TRUE(a.cloud && b.cloud);
    p.min_overlap = 0.99;
    const auto r = register_pair(*a.cloud, *b.cloud, p, Settings{}, 1);
    EXPECT_FALSE(r.matched);
    EXPECT_NE(r.reason.find("below min_overlap"), std::string::npos) << r.reason;
}

TEST(FpfhMatcher, APairPastItsTimeLimitIsATimeoutNotAHang) {
    const auto a = prepare(scan("bun000.ply"), bunny_params());
    const auto b = prepare(scan("bun045.ply"), bunny_params());
    ASSERT_TRUE(a.cloud && b.cloud);
    Settings s;
    s.pair_time_limit_s = 0;
    const auto r = register_pair(*a.cloud, *b.cloud, bunny_params(), s, 1);
    EXPECT_FALSE(r.matched);
    EXPECT_TRUE(r.timed_out);
    EXPECT_NE(r.reason.find("pair time limit"), std::string::npos) << r.reason;
}

TEST(FpfhMatcher, TooFewPointsAreAReasonNotACrash) {
    const auto r = prepare({Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1, 0, 0)}, Params{});
    EXPECT_FALSE(r.cloud);
    EXPECT_NE(r.reason.find("after the voxel grid"), std::string::npos) << r.reason;
}

TEST(FpfhMatcher, ParametersAreCheckedByName) {
    std::map<std::string, double> v = {{"voxel_m", 0.1},    {"normal_scale", 2.5}, {"feature_scale", 5},
                                       {"n_corr", 2},       {"similarity", 0.9},   {"inlier_scale", 1.5},
                                       {"gicp_scale", 2.0}, {"min_overlap", 0.3}};
    ASSERT_EQ(v.size(), param_names().size());
    for (const auto& name : param_names()) EXPECT_TRUE(v.count(name)) << name;
    EXPECT_EQ(params_from(v).n_corr, 2);
    auto missing = v;
    missing.erase("similarity");
    try {
        params_from(missing);
        FAIL() << "a missing key was accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("'similarity' is missing"), std::string::npos) << e.what();
    }
    auto bad = v;
    bad["voxel_m"] = -1;
    EXPECT_THROW(params_from(bad), std::invalid_argument);
    bad = v;
    bad["min_overlap"] = std::nan("");
    EXPECT_THROW(params_from(bad), std::invalid_argument);
    bad = v;
    bad["feature_scale"] = 50;  // thousands of neighbours per point: refused, not run for hours
    EXPECT_THROW(params_from(bad), std::invalid_argument);
}

}  // namespace
}  // namespace maptune::fpfh
