#include "evaluation/evaluation.hpp"

#include <gtest/gtest.h>

#include <map>

#include <filesystem>
#include <fstream>

#include "dataset/simulator.hpp"
#include "temp_dataset.hpp"

namespace maptune::evaluation {
namespace {

namespace fs = std::filesystem;

class EvaluationTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        root_ = test::make_temp_dir("maptune_evaluation_test_");
        test::generate_tiny_dataset(root_, "ds", 1, 3);
    }
    static void TearDownTestSuite() { fs::remove_all(root_); }
    static params::ParameterSpace space() {
        return params::ParameterSpace::load(std::string(MAPTUNE_SOURCE_DIR) + "/configs/spaces/lru_matcher.yaml");
    }
    static fs::path root_;
};
fs::path EvaluationTest::root_;

TEST_F(EvaluationTest, EvaluatesEveryPairOfTheViewWithStatuses) {
    const auto ds = dataset::Dataset::open(root_ / "ds");
    matcher::MatcherSettings settings;
    settings.threads = 2;
    Evaluator ev(ds, space(), settings);
    matcher::EvaluationStats stats;
    const auto obs = ev.evaluate(dataset::View::complete, space().defaults(), &stats);
    ASSERT_EQ(obs.pairs.size(), 3u);
    EXPECT_EQ(obs.key.view, "complete");
    EXPECT_EQ(obs.key.dataset_id, ds.manifest().id);
    EXPECT_EQ(obs.key.params_key, space().canonical_key(space().defaults()));
    EXPECT_EQ(obs.pairs[0].pair_id, "run00/submap000|run00/submap001");
    for (const auto& p : obs.pairs) {
        if (p.status == store::PairStatus::kFailed || p.status == store::PairStatus::kTimeout) {
            EXPECT_FALSE(p.reason.empty());
        }
        EXPECT_EQ(p.matched, p.status == store::PairStatus::kOk);
    }
    EXPECT_GT(obs.wall_seconds, 0);
    EXPECT_EQ(stats.pairs, 3);
}

TEST_F(EvaluationTest, CachedEvaluationStoresOnceAndAnswersFromTheStore) {
    const auto ds = dataset::Dataset::open(root_ / "ds");
    store::ObservationStore db((root_ / "obs.db").string());
    Evaluator ev(ds, space());
    auto set = space().defaults();
    set.set("t_K", 0.951);  // rounds to 0.95
    bool from_store = true;
    const auto first = ev.evaluate_cached(&db, dataset::View::subsequent, set, &from_store);
    EXPECT_FALSE(from_store);
    EXPECT_EQ(db.count(), 1u);
    set.set("t_K", 0.949);  // same rounded key
    const auto second = ev.evaluate_cached(&db, dataset::View::subsequent, set, &from_store);
    EXPECT_TRUE(from_store);
    EXPECT_EQ(db.count(), 1u);
    ASSERT_EQ(first.pairs.size(), second.pairs.size());
    for (std::size_t i = 0; i < first.pairs.size(); ++i) {
        EXPECT_EQ(first.pairs[i].T_a_b_est, second.pairs[i].T_a_b_est);
    }
}

// Timeouts depend on the machine's load: such an answer is returned but never stored, so
// asking again runs the matcher again.
TEST_F(EvaluationTest, AnswersWithTimeoutsAreNotStored) {
    const auto ds = dataset::Dataset::open(root_ / "ds");
    store::ObservationStore db((root_ / "timeouts.db").string());
    matcher::MatcherSettings settings;
    settings.pair_time_limit_s = 1e-6;  // nothing finishes in a microsecond
    Evaluator ev(ds, space(), settings);
    bool from_store = true;
    const auto obs = ev.evaluate_cached(&db, dataset::View::complete, space().defaults(), &from_store);
    EXPECT_FALSE(from_store);
    ASSERT_TRUE(store::has_timeouts(obs.pairs));
    EXPECT_EQ(db.count(), 0u);
    ev.evaluate_cached(&db, dataset::View::complete, space().defaults(), &from_store);
    EXPECT_FALSE(from_store);
}

// Issue 12: `evaluate` stored results of a dataset whose files had changed under its content
// id; now nothing is stored and the error names the directory.
TEST_F(EvaluationTest, AChangedDatasetIsRefusedBeforeAnythingIsStored) {
    const fs::path copy = root_ / "changed";
    fs::copy(root_ / "ds", copy, fs::copy_options::recursive);
    const dataset::Dataset ds = dataset::Dataset::open(copy);
    std::ofstream(copy / ds.manifest().runs[0].gt_file, std::ios::app) << "\n";
    const dataset::Dataset changed = dataset::Dataset::open(copy);
    Evaluator ev(changed, space());
    store::ObservationStore db((root_ / "changed.db").string());
    try {
        ev.evaluate_cached(&db, dataset::View::subsequent, {});
        FAIL() << "stored results of a changed dataset";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("changed: its files changed since the manifest"), std::string::npos)
            << e.what();
    }
    EXPECT_EQ(db.count(), 0u);
}

TEST_F(EvaluationTest, MatcherSettingsArePartOfTheKey) {
    matcher::MatcherSettings a, b;
    b.ransac_iterations = a.ransac_iterations + 1;
    EXPECT_NE(matcher_version(a), matcher_version(b));
    matcher::MatcherSettings c = a;
    c.threads = 7;  // does not change results
    EXPECT_EQ(matcher_version(a), matcher_version(c));
}

// Issue 12: matcher_version and the feature fingerprint come from the one settings table, so a
// setting cannot be missed; this pins which ones are per-submap. A new setting fails this test
// until it has a value here.
TEST_F(EvaluationTest, EverySettableMatcherSettingChangesTheVersion) {
    const std::map<std::string, std::pair<std::string, bool>> other_value{  // value, per-submap
        {"collinear_inlier_fraction", {"0.5", false}}, {"consensus_from_n_TF", {"true", false}},
        {"icp_enabled", {"false", false}}, {"icp_max_correspondence_m", {"0.3", false}},
        {"icp_max_iterations", {"7", false}}, {"icp_point_to_plane", {"false", true}},
        {"icp_source_voxel_factor", {"3", true}}, {"icp_voxel_m", {"0.2", true}},
        {"line_threshold_m", {"0.2", false}}, {"line_ransac_iterations", {"50", false}},
        {"lrf_method", {"board", true}},
        {"pair_time_limit_s", {"5", false}}, {"submap_time_limit_s", {"5", false}},
        {"total_time_limit_s", {"600", false}},
        {"max_roll_pitch_rad", {"0.2", false}}, {"min_icp_inlier_fraction", {"0.3", false}},
        {"min_keypoints", {"9", true}}, {"min_points", {"99", true}},
        {"min_ransac_inliers", {"8", false}}, {"outlier_mean_k", {"9", true}},
        {"outlier_removal", {"false", true}}, {"outlier_stddev_mul", {"1.5", true}},
        {"ransac_inlier_threshold_m", {"0.3", false}}, {"ransac_iterations", {"99", false}},
        {"ransac_threshold_from", {"v_TF", false}}, {"seed", {"7", false}},
        {"surface_points_per_radius", {"5", true}}, {"unknown_samples_per_diameter", {"8", true}},
        {"viewpoint_x", {"1", true}}, {"viewpoint_y", {"1", true}}, {"viewpoint_z", {"1", true}},
        {"max_free_space_fraction", {"0.2", true}}, {"free_space_margin_m", {"0.2", false}},
    };
    const matcher::MatcherSettings defaults;
    for (const auto& key : matcher::matcher_setting_names()) {
        const auto it = other_value.find(key);
        ASSERT_NE(it, other_value.end()) << "setting " << key << " has no test value: add it here";
        matcher::MatcherSettings s;
        ASSERT_EQ(matcher::set_matcher_setting(s, key, it->second.first), "") << key;
        EXPECT_NE(matcher_version(s), matcher_version(defaults)) << key << " does not change the matcher version";
        EXPECT_EQ(matcher::feature_settings_fingerprint(s) != matcher::feature_settings_fingerprint(defaults),
                  it->second.second)
            << key << (it->second.second ? " does not change" : " changes") << " the feature fingerprint";
    }
    EXPECT_EQ(matcher::matcher_setting_names().size(), other_value.size());
}

// Stores outlive code: a setting added after revision 4 must not change the version of the
// settings that existed before (at its default it is left out), or every stored observation
// would be recomputed. The pinned value is what the quick kit's runs (pair and total time limits
// 20 s and 600 s, all else default) recorded in run.yaml before the free-space check existed.
TEST_F(EvaluationTest, NewSettingsAtTheirDefaultKeepTheVersionOfEarlierStores) {
    matcher::MatcherSettings kit;
    ASSERT_EQ(matcher::set_matcher_settings(kit, {"pair_time_limit_s=20", "total_time_limit_s=600"}), "");
    EXPECT_EQ(matcher_version(kit), "4-acf16e16");
    matcher::MatcherSettings s = kit;
    ASSERT_EQ(matcher::set_matcher_setting(s, "max_free_space_fraction", "0.05"), "");
    EXPECT_NE(matcher_version(s), matcher_version(kit));
}

// What a task carries: every setting as text, which gives back the same matcher on any worker.
TEST_F(EvaluationTest, SettingTextsRoundTripToTheSameVersion) {
    matcher::MatcherSettings s;
    ASSERT_EQ(matcher::set_matcher_settings(s, {"min_ransac_inliers=0", "icp_voxel_m=0.07", "lrf_method=board",
                                                "ransac_threshold_from=v_TF", "seed=12345678901"}),
              "");
    s.viewpoint_z = 1.0 / 3.0;  // not a short decimal
    matcher::MatcherSettings back;
    back.threads = 3;
    ASSERT_EQ(matcher::set_matcher_settings(back, matcher::setting_texts(s)), "");
    EXPECT_EQ(matcher_version(back), matcher_version(s));
    EXPECT_EQ(matcher::feature_settings_fingerprint(back), matcher::feature_settings_fingerprint(s));
    EXPECT_EQ(back.viewpoint_z, s.viewpoint_z);
    EXPECT_EQ(back.seed, s.seed);
    EXPECT_EQ(matcher::setting_texts(s).size(), matcher::setting_fields().size());
    EXPECT_EQ(matcher_version(s).rfind(std::string(kMatcherCodeRevision) + "-", 0), 0u);
}

}  // namespace
}  // namespace maptune::evaluation
