// The real PCL worker backend on a tiny dataset: tasks run the matcher, and loaded submaps are
// kept in a bounded cache (issue 12: a worker used to keep every submap it ever loaded).
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <random>
#include <set>

#include "dataset/dataset.hpp"
#include "dataset_mirror.hpp"
#include "dds/participant.hpp"
#include "fastdds_shm.hpp"
#include "temp_dataset.hpp"
#include "test_domain.hpp"
#include "worker_backend.hpp"

namespace maptune {
namespace {

namespace fs = std::filesystem;
const std::string kSource = MAPTUNE_SOURCE_DIR;

// The matcher version of the default settings with one changed.
std::string matcher_version_with(const std::string& key_value) {
    matcher::MatcherSettings s;
    EXPECT_EQ(matcher::set_matcher_settings(s, {key_value}), "");
    return evaluation::matcher_version(s);
}

// A tiny lab (one run of 4 submaps: 6 complete pairs) behind a mirror on a private domain.
class LruBackend : public ::testing::Test {
protected:
    void SetUp() override {
        dir = test::make_temp_dir("maptune_worker_backend_");
        shm_before = testing::fastdds_shm_files();
        lab = test::generate_tiny_dataset(dir, "lab", 1, 4, 2);
        const int domain = test::reserve_domain();
        participant = std::make_unique<dds::Participant>(dds::ParticipantOptions{domain, "", "maptune_loopback", "worker"});
        mirror = std::make_unique<services::DatasetMirror>(*participant, dir / "cache", "worker");
        mirror->add_local(lab);
    }
    void TearDown() override {
        mirror.reset();
        participant.reset();
        testing::remove_orphaned_fastdds_shm(shm_before);
        fs::remove_all(dir);
    }
    // The baseline on every complete pair.
    services::TaskSpec complete_task() const {
        const dataset::Dataset ds = dataset::Dataset::open(lab);
        services::TaskSpec task;
        task.task_id = "t1";
        task.dataset_id = ds.manifest().id;
        task.view = "complete";
        task.params = space.round(space.complete({}));
        for (const auto& pair : ds.pairs(dataset::View::complete, dataset::Reference::gt)) {
            task.pair_ids.push_back(pair.id_a + "|" + pair.id_b);
        }
        return task;
    }

    fs::path dir, lab;
    std::set<std::string> shm_before;
    const params::ParameterSpace space = params::ParameterSpace::load(kSource + "/configs/spaces/lru_matcher.yaml");
    std::unique_ptr<dds::Participant> participant;
    std::unique_ptr<services::DatasetMirror> mirror;
};

TEST_F(LruBackend, RunsTheMatcherWithABoundedSubmapCache) {
    {
        matcher::MatcherSettings settings;
        settings.threads = 1;
        // Room for about one submap: every new one evicts the least recently used.
        services::LruBackend small(*mirror, space, settings, {}, 1);
        services::LruBackend roomy(*mirror, space, settings);

        const services::TaskSpec task = complete_task();
        ASSERT_EQ(task.pair_ids.size(), 6u);

        const auto a = small.run(task);
        ASSERT_TRUE(a.ok) << a.error;
        ASSERT_EQ(a.pairs.size(), 6u);
        const auto s = small.submap_cache_stats();
        EXPECT_EQ(s.entries, 1u) << "bounded: only the most recent submap stays";
        EXPECT_EQ(s.misses, 4u) << "each submap loaded once per task";
        EXPECT_EQ(s.evictions, 3u);

        const auto b = roomy.run(task);
        ASSERT_TRUE(b.ok) << b.error;
        EXPECT_EQ(roomy.submap_cache_stats().entries, 4u);
        const auto again = roomy.run(task);
        EXPECT_EQ(roomy.submap_cache_stats().misses, 4u) << "a second task is served from the cache";
        // Eviction changes nothing in the answer.
        for (std::size_t i = 0; i < a.pairs.size(); ++i) {
            EXPECT_EQ(a.pairs[i].pair_id, b.pairs[i].pair_id);
            EXPECT_EQ(a.pairs[i].matched, b.pairs[i].matched) << a.pairs[i].pair_id;
            EXPECT_TRUE(a.pairs[i].T_a_b_est.isApprox(b.pairs[i].T_a_b_est, 1e-6)) << a.pairs[i].pair_id;
            EXPECT_EQ(again.pairs[i].matched, b.pairs[i].matched);
        }

        // A submap that cannot be loaded fails the task with a message naming it.
        auto bad = task;
        bad.pair_ids = {"run00/submap000|run00/submap999"};
        const auto failed = small.run(bad);
        EXPECT_FALSE(failed.ok);
        EXPECT_NE(failed.error.find("submap999"), std::string::npos) << failed.error;
    }
}

// Issue 12: matcher settings travel in the task, so a worker started with defaults evaluates an
// experiment's settings exactly as a worker started with them would; settings that do not make
// the version asked for, or another version without settings, are refused with the reason.
TEST_F(LruBackend, RunsTheSettingsATaskCarries) {
    {
        matcher::MatcherSettings defaults;
        defaults.threads = 1;
        // An experiment's settings that change which pairs match: no consensus check, PCL's
        // RANSAC threshold, no ICP.
        matcher::MatcherSettings experiment = defaults;
        ASSERT_EQ(matcher::set_matcher_settings(experiment, {"min_ransac_inliers=0", "ransac_threshold_from=v_TF",
                                                             "icp_enabled=false"}),
                  "");
        services::LruBackend plain(*mirror, space, defaults);
        services::LruBackend started_with(*mirror, space, experiment);
        ASSERT_NE(plain.matcher_version(), started_with.matcher_version());
        EXPECT_TRUE(plain.takes_settings());

        const services::TaskSpec task = complete_task();
        const auto own = plain.run(task);
        ASSERT_TRUE(own.ok) << own.error;

        services::TaskSpec carried = task;
        carried.matcher_version = started_with.matcher_version();
        carried.matcher_settings = matcher::setting_texts(experiment);
        const auto a = plain.run(carried);
        const auto b = started_with.run(task);
        ASSERT_TRUE(a.ok) << a.error;
        ASSERT_TRUE(b.ok) << b.error;
        ASSERT_EQ(a.pairs.size(), b.pairs.size());
        int differ_from_defaults = 0;
        for (std::size_t i = 0; i < a.pairs.size(); ++i) {
            EXPECT_EQ(a.pairs[i].matched, b.pairs[i].matched) << a.pairs[i].pair_id;
            EXPECT_EQ(a.pairs[i].status, b.pairs[i].status) << a.pairs[i].pair_id;
            EXPECT_TRUE(a.pairs[i].T_a_b_est.isApprox(b.pairs[i].T_a_b_est, 1e-9)) << a.pairs[i].pair_id;
            if (a.pairs[i].matched != own.pairs[i].matched ||
                !a.pairs[i].T_a_b_est.isApprox(own.pairs[i].T_a_b_est, 1e-9))
                ++differ_from_defaults;
        }
        EXPECT_GT(differ_from_defaults, 0) << "the carried settings must have been applied";
        EXPECT_EQ(plain.matchers_held(), 2u);

        // The task's settings must make the version it asks for.
        services::TaskSpec lying = carried;
        lying.matcher_settings = matcher::setting_texts(defaults);
        lying.matcher_version = matcher_version_with("seed=7");
        const auto refused = plain.run(lying);
        EXPECT_FALSE(refused.ok);
        EXPECT_NE(refused.error.find("not the " + lying.matcher_version), std::string::npos) << refused.error;
        services::TaskSpec bad = carried;
        bad.matcher_version = matcher_version_with("seed=7");
        bad.matcher_settings = {"min_ransac_inliers=-1"};
        EXPECT_NE(plain.run(bad).error.find("min_ransac_inliers"), std::string::npos);
        services::TaskSpec bare = carried;
        bare.matcher_settings.clear();
        bare.matcher_version = matcher_version_with("seed=8");
        EXPECT_NE(plain.run(bare).error.find("carries no settings"), std::string::npos);
        EXPECT_LE(plain.matchers_held(), services::LruBackend::kMaxMatchers);
    }
}

}  // namespace
}  // namespace maptune
