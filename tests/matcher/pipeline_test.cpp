#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "matcher/matcher.hpp"
#include "test_scene.hpp"

namespace maptune::matcher {
namespace {

using test::make_scene_submap;

double rotation_error_deg(const Eigen::Matrix4d& T_est, const Eigen::Matrix4d& T_ref) {
    const Eigen::Matrix3d R = T_ref.topLeftCorner<3, 3>().transpose() * T_est.topLeftCorner<3, 3>();
    return Eigen::AngleAxisd(R).angle() * 180.0 / M_PI;
}

Eigen::Isometry3f pose(float yaw, float x, float y) {
    Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
    T.linear() = Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3f(x, y, 0.f);
    return T;
}

MatcherSettings fast_settings() {
    MatcherSettings s;
    s.threads = 2;
    s.icp_voxel_m = 0.05;  // the synthetic scene is sampled at 5 cm
    return s;
}

class ScenePair : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        a_ = new dataset::Submap(make_scene_submap("scene/a", 0.f, 4.5f, 6.f, pose(0.f, 0.f, 0.f)));
        b_ =
            new dataset::Submap(make_scene_submap("scene/b", 1.5f, 6.f, 6.f, pose(0.5f, 2.f, 1.f)));
    }
    static void TearDownTestSuite() {
        delete a_;
        delete b_;
    }
    static Eigen::Matrix4d reference() {
        return (a_->T_world_submap_gt.inverse() * b_->T_world_submap_gt).matrix();
    }
    static dataset::Submap* a_;
    static dataset::Submap* b_;
};
dataset::Submap* ScenePair::a_ = nullptr;
dataset::Submap* ScenePair::b_ = nullptr;

TEST_F(ScenePair, BaselineMatchesWithSmallError) {
    Matcher m(fast_settings());
    const auto r = m.match(*a_, *b_, MatcherParams{});
    ASSERT_EQ(r.status, MatchStatus::kOk)
        << r.reason << " corr=" << r.correspondences << " groups=" << r.groups;
    EXPECT_TRUE(r.matched);
    EXPECT_LT(rotation_error_deg(r.T_a_b, reference()), 1.0);
    EXPECT_LT((r.T_a_b.topRightCorner<3, 1>() - reference().topRightCorner<3, 1>()).norm(), 0.05)
        << "group=" << r.group_size << " inliers=" << r.ransac_inliers << " groups=" << r.groups
        << " corr=" << r.correspondences << " kp=" << r.keypoints_a << "/" << r.keypoints_b
        << " icp=" << r.icp_fitness << "\n"
        << r.T_a_b << "\nref\n"
        << reference();
}

TEST_F(ScenePair, ConsensusCheckTurnsAWeakTransformIntoNoMatch) {
    MatcherSettings s = fast_settings();
    Matcher m(s);
    const auto ok = m.match(*a_, *b_, MatcherParams{});
    ASSERT_EQ(ok.status, MatchStatus::kOk) << ok.reason;
    ASSERT_GE(ok.ransac_inliers, s.min_ransac_inliers);
    // The same pair, demanding one inlier more than RANSAC found: no match, and no ICP ran.
    s.min_ransac_inliers = ok.ransac_inliers + 1;
    Matcher strict(s);
    const auto r = strict.match(*a_, *b_, MatcherParams{});
    EXPECT_EQ(r.status, MatchStatus::kNoMatch);
    EXPECT_FALSE(r.matched);
    EXPECT_EQ(r.reason, "too few RANSAC inliers");
    EXPECT_EQ(r.ransac_inliers, ok.ransac_inliers);
    EXPECT_LT(r.icp_fitness, 0.0);
}

TEST_F(ScenePair, DeterministicGivenSeed) {
    Matcher m1(fast_settings()), m2(fast_settings());
    const auto r1 = m1.match(*a_, *b_, MatcherParams{});
    const auto r2 = m2.match(*a_, *b_, MatcherParams{});
    EXPECT_EQ(r1.status, r2.status);
    EXPECT_EQ(r1.T_a_b, r2.T_a_b);
    EXPECT_EQ(r1.correspondences, r2.correspondences);
}

TEST_F(ScenePair, CacheReusedWhenOnlyPairStageParametersChange) {
    Matcher m(fast_settings());
    std::vector<const dataset::Submap*> submaps{a_, b_};
    EvaluationStats st;
    MatcherParams p;
    m.match_pairs(submaps, {{0, 1}, {1, 0}}, p, &st);
    EXPECT_EQ(st.cache_misses, 2u);
    EXPECT_EQ(st.cache_hits, 0u);

    p.n_C = 5, p.t_C = 0.8, p.v_TF = 0.3, p.n_TF = 4;
    m.match_pairs(submaps, {{0, 1}}, p, &st);
    EXPECT_EQ(st.cache_misses, 0u);
    EXPECT_EQ(st.cache_hits, 2u);

    p.r_D = 0.3;  // a per-submap parameter: recompute
    m.match_pairs(submaps, {{0, 1}}, p, &st);
    EXPECT_EQ(st.cache_misses, 2u);
    EXPECT_EQ(m.cache().stats().entries, 4u);
}

TEST_F(ScenePair, NeighbourListsReusedForNewPairStageParametersWithTheSameResult) {
    std::vector<const dataset::Submap*> submaps{a_, b_};
    MatcherParams p;
    Matcher m(fast_settings());
    EvaluationStats st;
    m.match_pairs(submaps, {{0, 1}}, p, &st);
    EXPECT_EQ(st.neighbour_hits, 0u);
    p.n_C = 5, p.t_C = 0.8, p.v_TF = 0.3, p.n_TF = 4;
    const auto reused = m.match_pairs(submaps, {{0, 1}}, p, &st).front();
    EXPECT_EQ(st.neighbour_hits, 1u);
    // A matcher that never saw the first parameter set computes the same.
    Matcher fresh(fast_settings());
    const auto direct = fresh.match_pairs(submaps, {{0, 1}}, p).front();
    EXPECT_EQ(reused.status, direct.status);
    EXPECT_EQ(reused.correspondences, direct.correspondences);
    EXPECT_EQ(reused.group_size, direct.group_size);
    EXPECT_EQ(reused.ransac_inliers, direct.ransac_inliers);
    EXPECT_TRUE(reused.T_a_b.isApprox(direct.T_a_b, 1e-9));
}

TEST_F(ScenePair, APairsTimeDoesNotDependOnWhatWasCached) {
    // Issue 16: run-time budgets compare a pair's seconds from the raw submaps; a worker that
    // had the features and descriptor lists cached must report the same costs.
    std::vector<const dataset::Submap*> submaps{a_, b_};
    MatcherParams p;
    Matcher m(fast_settings());
    const auto cold = m.match_pairs(submaps, {{0, 1}}, p).front();
    const auto warm = m.match_pairs(submaps, {{0, 1}}, p).front();
    EXPECT_GT(cold.features_s, 0.0);
    EXPECT_EQ(warm.features_s, cold.features_s) << "both submaps' feature times, as recorded";
    EXPECT_GE(warm.descriptor_s, cold.descriptor_s * 0.5) << "the cached lists' computing time counts";
    EXPECT_GT(warm.duration_s + warm.features_s, 0.5 * (cold.duration_s + cold.features_s));
}

TEST_F(ScenePair, CacheEvictsByEntriesAndBytes) {
    FeatureCacheOptions opt;
    opt.max_entries = 1;
    Matcher m(fast_settings(), opt);
    m.features(*a_, MatcherParams{});
    m.features(*b_, MatcherParams{});
    EXPECT_EQ(m.cache().stats().entries, 1u);
    EXPECT_EQ(m.cache().stats().evictions, 1u);
    m.features(*b_, MatcherParams{});  // most recent survives
    EXPECT_EQ(m.cache().stats().hits, 1u);
    opt.max_entries = 100;
    opt.max_bytes = 1;  // everything but the newest entry is evicted
    Matcher m2(fast_settings(), opt);
    m2.features(*a_, MatcherParams{});
    m2.features(*b_, MatcherParams{});
    EXPECT_EQ(m2.cache().stats().entries, 1u);
}

TEST_F(ScenePair, ExtremeParametersFinishWithoutCrash) {
    MatcherSettings s = fast_settings();
    s.pair_time_limit_s = 20;
    Matcher m(s);
    MatcherParams p{2.0, 0.05, 1.0, 2.0, 10, 1.0, 1.0, 0.1, 3};
    const auto r = m.match(*a_, *b_, p);
    EXPECT_NE(r.status, MatchStatus::kFailed) << r.reason;
    MatcherParams q{0.1, 0.5, 0.0, 0.1, 1, 0.0, 0.1, 1.0, 300};
    const auto r2 = m.match(*a_, *b_, q);
    EXPECT_FALSE(r2.matched);
}

TEST_F(ScenePair, UnknownSpaceFilterRemovesAllKeypointsForX1D) {
    // The octree knows only a thin layer around the ground: most of any big ball is unknown.
    auto tree = std::make_shared<octomap::OcTree>(0.1);
    for (float x = 0; x < 4.5f; x += 0.1f)
        for (float y = 0; y < 6.f; y += 0.1f) {
            tree->updateNode(octomap::point3d(x, y, 0.05f), true);
            tree->updateNode(octomap::point3d(x, y, 0.15f), false);
        }
    dataset::Submap a = *a_;
    a.octree = tree;
    Matcher m(fast_settings());
    const MatcherParams x1d{0.65, 0.05, 0.4, 1.2, 1, 0.6, 0.3, 0.3, 123};
    const auto f = m.features(a, x1d);
    EXPECT_EQ(f->status, FeatureStatus::kFailed);
    EXPECT_GT(f->keypoints_voxel, 0);
    EXPECT_EQ(f->keypoints_unknown, 0);
    EXPECT_NE(f->reason.find("unknown-space"), std::string::npos) << f->reason;
    EXPECT_EQ(m.match(a, *b_, x1d).status, MatchStatus::kFailed);

    MatcherParams keep_all = x1d;  // x'_1D: t_K = 1 keeps all
    keep_all.t_K = 1.0;
    const auto g = m.features(a, keep_all);
    EXPECT_EQ(g->status, FeatureStatus::kOk) << g->reason;
    EXPECT_EQ(g->keypoints_unknown, g->keypoints_voxel);
    // A null octree keeps all too.
    const auto h = m.features(*a_, x1d);
    EXPECT_EQ(h->keypoints_unknown, h->keypoints_voxel);
}

// An OctoMap as a down-looking sensor would make of `s`'s scene (the submap frame is gravity
// aligned here): every point occupied, the air up to 1 m above it free.
std::shared_ptr<octomap::OcTree> seen_from_above(const dataset::Submap& s) {
    auto tree = std::make_shared<octomap::OcTree>(0.05);
    for (const auto& p : s.cloud)
        for (float z = 0.1f; z <= 1.f; z += 0.05f) tree->updateNode(octomap::point3d(p.x, p.y, p.z + z), false);
    for (const auto& p : s.cloud) tree->updateNode(octomap::point3d(p.x, p.y, p.z), true);
    return tree;
}

TEST_F(ScenePair, FreeSpaceCheckKeepsTheRightMatchAndRejectsRocksInTheAir) {
    dataset::Submap a = *a_, b = *b_;
    a.octree = seen_from_above(a);
    b.octree = seen_from_above(b);
    MatcherSettings s = fast_settings();
    s.max_free_space_fraction = 0.05;
    Matcher m(s);
    const MatcherParams params;
    const auto fa = m.features(a, params), fb = m.features(b, params);
    ASSERT_TRUE(fa->octree && fb->octree) << "features keep the OctoMap when the check is on";
    EXPECT_FALSE(Matcher(fast_settings()).features(a, params)->octree) << "and only then";

    // The true transform: b's points lie on a's surfaces, nothing in a's air.
    const Eigen::Matrix4f T = reference().cast<float>();
    const auto right = free_space_counts(*fa, *fb, T, s.free_space_margin_m, 400);
    EXPECT_GT(right.known, 50);
    EXPECT_GT(right.reverse_known, 50);
    EXPECT_LT(right.worst_fraction(20), 0.02);
    // Lifted by 0.4 m (a rock's height), b floats in a's observed air.
    Eigen::Matrix4f lifted = T;
    lifted(2, 3) += 0.4f;
    const auto wrong = free_space_counts(*fa, *fb, lifted, s.free_space_margin_m, 400);
    EXPECT_GT(wrong.worst_fraction(20), 0.5);
    // Without an octree there is nothing to argue with.
    EXPECT_EQ(free_space_counts(*Matcher(fast_settings()).features(a, params), *fb, lifted, 0.1, 400).known, 0);

    const auto ok = m.match(a, b, params);
    EXPECT_EQ(ok.status, MatchStatus::kOk) << ok.reason;

    // The same pair, but b's OctoMap saw another scene (rocks elsewhere): a's rocks, placed in b
    // by the match, stand in b's free air, and the match is rejected by name.
    dataset::Submap b_elsewhere = b;
    b_elsewhere.id = "scene/b_elsewhere";  // features are cached by submap id
    b_elsewhere.octree = seen_from_above(make_scene_submap("scene/other", 1.5f, 6.f, 6.f, pose(0.5f, 2.f, 1.f), 99));
    const auto rejected = m.match(a, b_elsewhere, params);
    EXPECT_EQ(rejected.status, MatchStatus::kNoMatch);
    EXPECT_FALSE(rejected.matched);
    EXPECT_NE(rejected.reason.find("free space contradicts the match"), std::string::npos) << rejected.reason;
}

TEST(PipelineFailures, EmptyTinyAndDegenerateInputs) {
    Matcher m(fast_settings());
    dataset::Submap empty;
    empty.id = "empty";
    const auto good = make_scene_submap("good", 0.f, 3.f, 3.f, pose(0, 0, 0));
    auto r = m.match(empty, good, MatcherParams{});
    EXPECT_EQ(r.status, MatchStatus::kFailed);
    EXPECT_NE(r.reason.find("too few points"), std::string::npos) << r.reason;

    dataset::Submap tiny;
    tiny.id = "tiny";
    for (int i = 0; i < 5; ++i) tiny.cloud.push_back({float(i), 0.f, 0.f, 1, 2, 3});
    r = m.match(good, tiny, MatcherParams{});
    EXPECT_EQ(r.status, MatchStatus::kFailed);

    dataset::Submap line;
    line.id = "line";
    for (int i = 0; i < 400; ++i) line.cloud.push_back({0.01f * i, 0.f, 0.f, 100, 100, 100});
    r = m.match(line, line, MatcherParams{});
    EXPECT_FALSE(r.matched);
    EXPECT_FALSE(r.reason.empty());

    dataset::Submap nan_cloud;
    nan_cloud.id = "nan";
    nan_cloud.cloud.assign(100, {std::nanf(""), 0.f, 0.f, 0, 0, 0});
    EXPECT_EQ(m.match(nan_cloud, good, MatcherParams{}).status, MatchStatus::kFailed);

    // Invalid pair indices are a status too.
    std::vector<const dataset::Submap*> s{&good};
    const auto res = m.match_pairs(s, {{0, 3}}, MatcherParams{});
    EXPECT_EQ(res.at(0).status, MatchStatus::kFailed);
}

TEST(PipelineFailures, TotalTimeLimitGivesTimeout) {
    MatcherSettings s = fast_settings();
    s.total_time_limit_s = 1e-9;
    Matcher m(s);
    const auto good = make_scene_submap("good", 0.f, 3.f, 3.f, pose(0, 0, 0));
    const auto r = m.match(good, good, MatcherParams{});
    EXPECT_EQ(r.status, MatchStatus::kTimeout);
}

}  // namespace
}  // namespace maptune::matcher
