#include "experiment/experiment.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "params/yaml_util.hpp"

namespace maptune::experiment {
namespace {

namespace fs = std::filesystem;

class ExperimentTest : public ::testing::Test {
protected:
    void SetUp() override {
        char tmpl[] = "/tmp/maptune_experiment_test_XXXXXX";
        ASSERT_NE(mkdtemp(tmpl), nullptr);
        dir_ = tmpl;
        fs::copy(std::string(MAPTUNE_SOURCE_DIR) + "/configs/spaces/lru_matcher.yaml", dir_ / "space.yaml");
        fs::copy(std::string(MAPTUNE_SOURCE_DIR) + "/configs/params/x_baseline.yaml", dir_ / "base.yaml");
    }
    void TearDown() override { fs::remove_all(dir_); }
    std::string write(const std::string& text) {
        const auto p = dir_ / "exp.yaml";
        std::ofstream(p) << text;
        return p.string();
    }
    void expect_error(const std::string& text, const std::string& fragment) {
        try {
            load_experiment(write(text));
            FAIL() << "accepted:\n" << text;
        } catch (const params::ConfigError& e) {
            EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
        }
    }
    fs::path dir_;
};

TEST_F(ExperimentTest, LoadsEverySectionWithPathsRelativeToTheFile) {
    const Experiment e = load_experiment(write(R"(
name: t
space: space.yaml
optimize: [t_K, r_D, n_TF]
fixed: {v_K: 0.2}
dataset: {dir: data/lab, generate: {preset: lab-tiny, runs: 2, submaps: 5, seed: 3, sim: {worlds: 2, voxel_m: 0.05}}}
view: complete
reference: odometry
measure: {e_star: 0.3, m_star: 12, w_v: 0.4}
budget: {evaluations: 17, seconds: 90}
optimizer: {acquisition: ucb, ucb_kappa: 5, seed: 9, batch: 2}
start_points: [base.yaml]
matcher: {threads: 1, pair_time_limit_s: 5, feature_cache_mb: 512, neighbour_cache_mb: 0}
workers: 3
)"));
    EXPECT_EQ(e.name, "t");
    EXPECT_EQ(e.optimize, (std::vector<std::string>{"t_K", "r_D", "n_TF"}));  // space order
    EXPECT_DOUBLE_EQ(e.fixed.get("v_K"), 0.2);
    EXPECT_DOUBLE_EQ(e.fixed.get("r_N"), 0.2);
    EXPECT_EQ(e.dataset_dir, (dir_ / "data/lab").string());
    ASSERT_TRUE(e.generate.has_value());
    EXPECT_EQ(e.generate->preset, "lab-tiny");
    EXPECT_EQ(e.generate->runs, 2);
    ASSERT_EQ(e.generate->sim.size(), 2u);
    EXPECT_EQ(e.generate->sim[0].key, "worlds");
    EXPECT_EQ(e.generate->sim[1].value, "0.05");
    EXPECT_NE(e.generate->sim[1].where.find(":6: dataset.generate.sim.voxel_m"), std::string::npos) << e.generate->sim[1].where;
    EXPECT_EQ(e.view, "complete");
    EXPECT_EQ(e.reference, "odometry");
    EXPECT_DOUBLE_EQ(e.e_star, 0.3);
    EXPECT_DOUBLE_EQ(*e.m_star, 12);
    EXPECT_EQ(e.max_evaluations, 17);
    EXPECT_EQ(e.acquisition, "ucb");
    EXPECT_EQ(e.batch, 2);
    ASSERT_EQ(e.start_points.size(), 1u);
    EXPECT_DOUBLE_EQ(e.start_points[0].get("v_K"), 0.2) << "fixed values override start files";
    EXPECT_EQ(e.workers, 3);
    EXPECT_EQ(e.feature_cache_mb, 512);
    EXPECT_EQ(e.neighbour_cache_mb, 0) << "0 turns the neighbour-list cache off";

    const auto box = search_space(e);
    ASSERT_EQ(box.size(), 3u);
    EXPECT_EQ(box[2].name, "n_TF");
    EXPECT_TRUE(box[2].is_integer);
    EXPECT_EQ(box[2].high, 300);
    const params::ParameterSet full = full_set(e, {0.5, 1.0, 42});
    EXPECT_EQ(full.size(), 9u);
    EXPECT_DOUBLE_EQ(full.get("r_D"), 1.0);
    EXPECT_DOUBLE_EQ(full.get("v_K"), 0.2);
    EXPECT_EQ(optimizer_values(e, full), (std::vector<double>{0.5, 1.0, 42}));
    EXPECT_EQ(optimizer_options(e).acquisition, bo::Acquisition::ucb);
}

TEST_F(ExperimentTest, SeedsAndValidationTargets) {
    const Experiment e = load_experiment(write(R"(
name: v
space: space.yaml
dataset: train
seeds: [3, 1, 2]
validate:
  - dataset: {dir: held/lab-101, generate: {preset: lab-tiny, seed: 101}}
  - label: moon
    dataset: /abs/moon
    view: subsequent
    reference: odometry
    m_star_per_pair: 0.08
  - {dataset: other, m_star: 12}
  - {dataset: auto-one, m_star: auto}
)"));
    EXPECT_EQ(e.seeds, (std::vector<std::uint64_t>{3, 1, 2}));  // in the order given
    ASSERT_EQ(e.validate.size(), 4u);
    EXPECT_EQ(e.validate[0].label, "lab-101");
    EXPECT_EQ(e.validate[0].dataset_dir, (dir_ / "held/lab-101").string());
    ASSERT_TRUE(e.validate[0].generate.has_value());
    EXPECT_EQ(e.validate[0].generate->seed, 101u);
    EXPECT_EQ(e.validate[0].view, "complete");
    EXPECT_EQ(e.validate[0].reference, "gt");
    EXPECT_FALSE(e.validate[0].m_star || e.validate[0].m_star_per_pair);
    EXPECT_EQ(e.validate[1].label, "moon");
    EXPECT_EQ(e.validate[1].dataset_dir, "/abs/moon");
    EXPECT_EQ(e.validate[1].view, "subsequent");
    EXPECT_EQ(e.validate[1].reference, "odometry");
    EXPECT_DOUBLE_EQ(*e.validate[1].m_star_per_pair, 0.08);
    EXPECT_DOUBLE_EQ(*e.validate[2].m_star, 12);
    EXPECT_FALSE(e.validate[3].m_star.has_value());
}

// Every experiment the project ships (the demo, the reproduction kit) loads: a typo in a key,
// a wrong relative path to a space or start point, or a bad view fails here, not after an hour.
TEST(ShippedExperiments, EveryConfigLoads) {
    int loaded = 0;
    for (const auto& entry : fs::recursive_directory_iterator(std::string(MAPTUNE_SOURCE_DIR) + "/configs/experiments")) {
        if (entry.path().extension() != ".yaml") continue;
        // Parameter sets sit beside some experiments (bench/x_baseline_n_TF_10.yaml): no name.
        std::ifstream in(entry.path());
        const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        if (text.rfind("name:", 0) != 0 && text.find("\nname:") == std::string::npos) continue;
        try {
            const Experiment e = load_experiment(entry.path().string());
            EXPECT_FALSE(e.name.empty()) << entry.path();
            ++loaded;
        } catch (const std::exception& err) {
            ADD_FAILURE() << entry.path() << ": " << err.what();
        }
    }
    EXPECT_GE(loaded, 10);
}

TEST_F(ExperimentTest, DefaultsOptimizeEverythingWithDerivedMStar) {
    const Experiment e = load_experiment(write("name: d\nspace: space.yaml\ndataset: ds\n"));
    EXPECT_EQ(e.optimize.size(), 9u);
    EXPECT_FALSE(e.m_star.has_value());
    EXPECT_FALSE(e.m_star_per_pair.has_value());
    EXPECT_EQ(e.view, "subsequent");
    const Experiment per_pair =
        load_experiment(write("name: d\nspace: space.yaml\ndataset: ds\nmeasure: {m_star_per_pair: 0.1465}\n"));
    EXPECT_DOUBLE_EQ(*per_pair.m_star_per_pair, 0.1465);
    EXPECT_FALSE(per_pair.m_star.has_value());
    EXPECT_EQ(e.reference, "gt");
    EXPECT_FALSE(e.generate.has_value());
    EXPECT_TRUE(e.seeds.empty());
    EXPECT_TRUE(e.validate.empty());
    // Issue 15: the optimizer's defaults, and each choice reaching the optimizer's options.
    EXPECT_EQ(optimizer_options(e).warping, bo::OutputWarping::automatic);
    EXPECT_EQ(optimizer_options(e).search, bo::SearchRegion::alternate);
    EXPECT_EQ(optimizer_options(e).gp.backend, gp::CholeskyBackend::eigen);
    const Experiment f = load_experiment(
        write("name: d\nspace: space.yaml\ndataset: ds\noptimizer: {warping: none, search: global}\n"));
    EXPECT_EQ(optimizer_options(f).warping, bo::OutputWarping::none);
    EXPECT_EQ(optimizer_options(f).search, bo::SearchRegion::global);
    EXPECT_TRUE(optimizer_options(e).quadratic_steps);
    EXPECT_FALSE(optimizer_options(load_experiment(write(
                     "name: d\nspace: space.yaml\ndataset: ds\noptimizer: {quadratic_steps: false}\n")))
                     .quadratic_steps);
    EXPECT_EQ(optimizer_options(e).hyper_samples, 4);
    EXPECT_EQ(optimizer_options(load_experiment(write(
                  "name: d\nspace: space.yaml\ndataset: ds\noptimizer: {hyper_samples: 0}\n")))
                  .hyper_samples,
              0);
    EXPECT_THROW(load_experiment(write("name: d\nspace: space.yaml\ndataset: ds\noptimizer: {hyper_samples: -1}\n")),
                 params::ConfigError);
    ASSERT_TRUE(optimizer_options(e).dead_value.has_value());  // p = 0: no match at all
    EXPECT_EQ(*optimizer_options(e).dead_value, 0.0);
    EXPECT_FALSE(optimizer_options(load_experiment(write(
                     "name: d\nspace: space.yaml\ndataset: ds\noptimizer: {dead_regions: false}\n")))
                     .dead_value.has_value());
    if (gp::cholmod_available()) {
        const Experiment g =
            load_experiment(write("name: d\nspace: space.yaml\ndataset: ds\noptimizer: {cholesky: cholmod}\n"));
        EXPECT_EQ(optimizer_options(g).gp.backend, gp::CholeskyBackend::cholmod);
    }
}

TEST_F(ExperimentTest, ErrorsNameTheKeyAndWhatWasExpected) {
    const std::string head = "name: x\nspace: space.yaml\ndataset: ds\n";
    expect_error(head + "optimize: [r_N, bogus]\n", "optimize[1]: unknown parameter 'bogus'");
    expect_error(head + "optimize: [r_N, r_N]\n", "optimize[1]: 'r_N' listed twice");
    expect_error(head + "optimize: [r_N]\nfixed: {r_N: 0.3}\n", "fixed.r_N: is optimized");
    expect_error(head + "optimize: [r_N]\nfixed: {n_C: 20}\n", "fixed.n_C: n_C: 20.0 is outside [1.0, 10.0]");
    expect_error(head + "view: sideways\n", "view: expected one of complete | subsequent, got 'sideways'");
    expect_error(head + "measure: {e_star: 0.01}\n", "measure.e_star: expected a number in");
    expect_error(head + "measure: {m_star: 10, m_star_per_pair: 0.1}\n", "give either 'm_star' or 'm_star_per_pair'");
    expect_error(head + "measure: {m_star_per_pair: 0}\n", "measure.m_star_per_pair: expected a number in");
    expect_error(head + "budget: {evaluations: 2.5}\n", "budget.evaluations: expected an integer");
    expect_error(head + "optimizer: {acquisition: pi}\n", "optimizer.acquisition: expected one of");
    expect_error(head + "optimizer: {warping: boxcox}\n", "optimizer.warping: expected one of");
    expect_error(head + "optimizer: {search: local}\n", "optimizer.search: expected one of");
    expect_error(head + "optimizer: {cholesky: lapack}\n", "optimizer.cholesky: expected one of");
    expect_error(head + "start_points: [missing.yaml]\n", "start_points[0]: ");
    expect_error(head + "colour: blue\n", "exp.yaml:4: colour: unknown key");
    expect_error(head + "seeds: [1, 2, 1]\n", "seeds[2]: seed 1 listed twice");
    expect_error(head + "seeds: []\n", "seeds: expected a non-empty list");
    expect_error(head + "validate: {dataset: ds}\n", "validate: expected a list");
    expect_error(head + "validate: [{view: complete}]\n", "validate[0]: missing key 'dataset'");
    expect_error(head + "validate: [{dataset: a, m_star: 3, m_star_per_pair: 0.1}]\n", "not both");
    expect_error(head + "matcher: {settings: [a, b]}\n", "matcher.settings");
    expect_error(head + "matcher: {settings: {lrf_method: [a]}}\n", "matcher.settings.lrf_method: expected a value");
    expect_error(head + "matcher: {id: my_icp, settings: {seed: 3}}\n", "settings apply to the reference matcher");
    expect_error(head + "matcher: {id: 'a b'}\n", "matcher.id: expected a matcher id");
    expect_error(head + "{a: 1}: 2\n", "expected a plain name as key");
    expect_error(head + "fixed: {[r_N]: 0.2}\n", "expected a plain name as key");
    expect_error(head + "validate: [{dataset: a/x}, {dataset: b/x}]\n", "label 'x' used twice");
    expect_error(head + "validate: [{dataset: a/pooled}]\n", "'pooled' is reserved");
    expect_error(head + "validate: [{dataset: a, reference: lidar}]\n", "validate[0].reference: expected one of");
    expect_error(head + "validate: [{dataset: {dir: a, generate: {preset: lab, sim: [worlds]}}}]\n",
                 "validate[0].dataset.generate.sim: expected a mapping");
    expect_error(head + "validate: [{dataset: {dir: a, generate: {preset: lab, sim: {worlds: [2]}}}}]\n",
                 "validate[0].dataset.generate.sim.worlds: expected a number");
    expect_error(head + "validate: [{dataset: {dir: a, generate: {preset: mars}}}]\n",
                 "validate[0].dataset.generate.preset: expected one of");
    expect_error("name: x\ndataset: ds\n", "missing key 'space'");
    expect_error("name: x\nspace: nope.yaml\ndataset: ds\n", "space: ");
}

}  // namespace
}  // namespace maptune::experiment
