// The real PCL worker backend on a tiny dataset: tasks run the matcher, and loaded submaps are
// kept in a bounded cache (issue 12: a worker used to keep every submap it ever loaded).
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "dataset/dataset.hpp"
#include "dataset_mirror.hpp"
#include "dds/participant.hpp"
#include "fastdds_shm.hpp"
#include "temp_dataset.hpp"
#include "worker_backend.hpp"

namespace maptune {
namespace {

namespace fs = std::filesystem;
const std::string kSource = MAPTUNE_SOURCE_DIR;

TEST(LruBackend, RunsTheMatcherWithABoundedSubmapCache) {
    const fs::path dir = test::make_temp_dir("maptune_worker_backend_");
    const auto shm_before = testing::fastdds_shm_files();
    const fs::path lab = test::generate_tiny_dataset(dir, "lab", 1, 4, 2);
    const dataset::Dataset ds = dataset::Dataset::open(lab);
    const auto space = params::ParameterSpace::load(kSource + "/configs/spaces/lru_matcher.yaml");
    const int domain = std::uniform_int_distribution<int>(1, 200)(*std::make_unique<std::random_device>());
    {
        dds::Participant p({domain, "", "maptune_loopback", "worker"});
        services::DatasetMirror mirror(p, dir / "cache", "worker");
        mirror.add_local(lab);
        matcher::MatcherSettings settings;
        settings.threads = 1;
        // Room for about one submap: every new one evicts the least recently used.
        services::LruBackend small(mirror, space, settings, {}, 1);
        services::LruBackend roomy(mirror, space, settings);

        services::TaskSpec task;
        task.task_id = "t1";
        task.dataset_id = ds.manifest().id;
        task.view = "complete";
        task.params = space.round(space.complete({}));
        for (const auto& pair : ds.pairs(dataset::View::complete, dataset::Reference::gt)) {
            task.pair_ids.push_back(pair.id_a + "|" + pair.id_b);
        }
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
    testing::remove_orphaned_fastdds_shm(shm_before);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace maptune
