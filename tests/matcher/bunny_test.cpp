// Real data: Stanford bunny scans with the bun.conf ground truth (see the data README).
#include <gtest/gtest.h>

#include "matcher/cloud_io.hpp"
#include "matcher/matcher.hpp"

namespace maptune::matcher {
namespace {

// In the repository (tests/data/stanford_bunny/README.md), so a bare clone runs this test.
const std::string kBunnyDir = MAPTUNE_SOURCE_DIR "/tests/data/stanford_bunny/";

// Baseline parameters scaled to a 0.15 m object scanned at ~0.5 mm spacing.
MatcherParams bunny_params() {
    MatcherParams p;
    p.r_N = 0.004;
    p.v_K = 0.006;
    p.t_K = 1.0;
    p.r_D = 0.02;
    p.n_C = 3;
    p.t_C = 0.5;
    p.r_LRF = 0.02;
    p.v_TF = 0.02;
    p.n_TF = 5;
    return p;
}

MatcherSettings bunny_settings() {
    MatcherSettings s;
    s.threads = 2;
    s.ransac_inlier_threshold_m = 0.004;
    s.icp_max_correspondence_m = 0.002;
    s.icp_max_iterations = 100;
    s.icp_voxel_m = 0.001;
    s.line_threshold_m = 0.003;
    return s;
}

struct BunnyCase {
    std::string target, source;
};

class BunnyPair : public ::testing::TestWithParam<BunnyCase> {};

TEST_P(BunnyPair, RegistersWithinOneDegreeAndTwoPercent) {
    const auto& c = GetParam();
    const auto poses = io::read_bunny_conf(kBunnyDir + "bun.conf");
    ASSERT_TRUE(poses.count(c.target) && poses.count(c.source)) << "missing bun.conf entries";
    const auto pa = io::read_xyz(kBunnyDir + c.target);
    const auto pb = io::read_xyz(kBunnyDir + c.source);
    ASSERT_GT(pa.size(), 10000u);
    ASSERT_GT(pb.size(), 10000u);
    const auto a = io::make_submap(c.target, pa);
    const auto b = io::make_submap(c.source, pb);
    const Eigen::Matrix4d T_ref = (poses.at(c.target).inverse() * poses.at(c.source)).matrix();

    Eigen::Vector3f lo = pa.front(), hi = pa.front();
    for (const auto& p : pa) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    const double extent = (hi - lo).maxCoeff();

    FeatureCacheOptions cache;
    cache.key_quantum = 1e-4;  // object scale: 2 decimals of a metre would merge all radii
    Matcher m(bunny_settings(), cache);
    const auto r = m.match(a, b, bunny_params());
    ASSERT_EQ(r.status, MatchStatus::kOk)
        << r.reason << " kp=" << r.keypoints_a << "/" << r.keypoints_b
        << " corr=" << r.correspondences << " groups=" << r.groups;
    const Eigen::Matrix3d dR =
        T_ref.topLeftCorner<3, 3>().transpose() * r.T_a_b.topLeftCorner<3, 3>();
    const double rot_deg = Eigen::AngleAxisd(dR).angle() * 180.0 / M_PI;
    const double trans = (r.T_a_b.topRightCorner<3, 1>() - T_ref.topRightCorner<3, 1>()).norm();
    EXPECT_LT(rot_deg, 1.0);
    EXPECT_LT(trans, 0.02 * extent);
    RecordProperty("rotation_error_deg", std::to_string(rot_deg));
    RecordProperty("translation_error_m", std::to_string(trans));
}

INSTANTIATE_TEST_SUITE_P(Scans, BunnyPair,
                         ::testing::Values(BunnyCase{"bun000.ply", "bun045.ply"},
                                           BunnyCase{"bun000.ply", "bun315.ply"},
                                           BunnyCase{"bun045.ply", "bun090.ply"}),
                         [](const auto& tp) {
                             auto strip = [](std::string s) { return s.substr(0, s.find('.')); };
                             return strip(tp.param.target) + "_" + strip(tp.param.source);
                         });

}  // namespace
}  // namespace maptune::matcher
