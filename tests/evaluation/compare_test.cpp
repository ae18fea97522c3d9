#include "evaluation/compare.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "dataset/simulator.hpp"
#include "temp_dataset.hpp"
#include "params/yaml_util.hpp"

namespace maptune::evaluation {
namespace {

namespace fs = std::filesystem;

TEST(KendallTauTest, KnownValues) {
    EXPECT_DOUBLE_EQ(kendall_tau_b({1, 2, 3, 4}, {10, 20, 30, 40}), 1.0);
    EXPECT_DOUBLE_EQ(kendall_tau_b({1, 2, 3, 4}, {4, 3, 2, 1}), -1.0);
    // One swapped neighbour pair of 4: (6 - 2) / 6 = 2/3.
    EXPECT_NEAR(kendall_tau_b({1, 2, 3, 4}, {1, 3, 2, 4}), 2.0 / 3.0, 1e-12);
    // Ties (tau-b): x = (1, 2, 2), y = (1, 2, 3): C = 2, D = 0, pairs untied in x 2, in y 3.
    EXPECT_NEAR(kendall_tau_b({1, 2, 2}, {1, 2, 3}), 2.0 / std::sqrt(6.0), 1e-12);
    // The thesis's lab scores against themselves and against the lab of issue 10's table:
    // 10 concordant, 5 discordant pairs of 15.
    const std::vector<double> thesis{0.53, 0.0, 0.64, 0.67, 0.71, 0.51};
    EXPECT_DOUBLE_EQ(kendall_tau_b(thesis, thesis), 1.0);
    EXPECT_NEAR(kendall_tau_b({0.910, 0.0, 0.883, 0.911, 0.707, 0.863}, thesis), 5.0 / 15.0, 1e-12);
    EXPECT_TRUE(std::isnan(kendall_tau_b({1, 1, 1}, {1, 2, 3})));
    EXPECT_TRUE(std::isnan(kendall_tau_b({1}, {1})));
    EXPECT_THROW(kendall_tau_b({1, 2}, {1}), std::invalid_argument);
}

TEST(CompareTargetTest, ParsesLabelDatasetViewAndReference) {
    auto t = parse_compare_target("datasets/lab");
    EXPECT_EQ(t.label, "lab");
    EXPECT_EQ(t.dataset, fs::path("datasets/lab"));
    EXPECT_EQ(t.view, dataset::View::complete);
    EXPECT_EQ(t.reference, dataset::Reference::gt);
    t = parse_compare_target("held=datasets/lab/:subsequent:odometry");
    EXPECT_EQ(t.label, "held");
    EXPECT_EQ(t.view, dataset::View::subsequent);
    EXPECT_EQ(t.reference, dataset::Reference::odometry);
    t = parse_compare_target("datasets/moon/:subsequent");
    EXPECT_EQ(t.label, "moon");
    EXPECT_EQ(t.reference, dataset::Reference::gt);
    EXPECT_THROW(parse_compare_target("d:sideways"), params::ConfigError);
    EXPECT_THROW(parse_compare_target("d:complete:truth"), params::ConfigError);
    EXPECT_THROW(parse_compare_target("=d"), params::ConfigError);
    try {
        parse_compare_target("lab:complete:truth");
        FAIL();
    } catch (const params::ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("truth"), std::string::npos) << e.what();
    }
}

class CompareTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        root_ = test::make_temp_dir("maptune_compare_test_");
        // Seed 5: the baseline matches some of its pairs (the CLI test uses the same).
        test::generate_tiny_dataset(root_, "tiny", 1, 4, 5);
    }
    static void TearDownTestSuite() { fs::remove_all(root_); }
    static std::string source(const std::string& rel) { return std::string(MAPTUNE_SOURCE_DIR) + "/" + rel; }
    static params::ParameterSpace space() { return params::ParameterSpace::load(source("configs/spaces/lru_matcher.yaml")); }
    static fs::path root_;
};
fs::path CompareTest::root_;

TEST_F(CompareTest, ThesisTableConfigLoadsWithItsSixSetsAndBothColumns) {
    const auto c = load_compare_config(source("configs/compare/thesis_table_5_2.yaml"));
    ASSERT_EQ(c.params.size(), 6u);
    for (const auto& p : c.params) EXPECT_TRUE(fs::exists(p)) << p;
    ASSERT_EQ(c.reference.size(), 2u);
    const auto* lab = find_reference_column(c.reference, "my_lab", "lab");
    ASSERT_NE(lab, nullptr);
    EXPECT_EQ(lab->name, "lab");
    EXPECT_NEAR(*lab->m_star_per_pair * 1365, 200, 0.01);
    EXPECT_DOUBLE_EQ(lab->scores.at("x_9D_ssgt1"), 0.71);
    const auto* moon = find_reference_column(c.reference, "sim", "");
    ASSERT_NE(moon, nullptr);
    EXPECT_EQ(moon->name, "moon");
    EXPECT_NEAR(*moon->m_star_per_pair * 31200, 2500, 0.02);
    EXPECT_EQ(find_reference_column(c.reference, "bunny", "import"), nullptr);
}

TEST_F(CompareTest, BadConfigNamesFileLineAndKey) {
    const fs::path f = root_ / "bad.yaml";
    std::ofstream(f) << "reference:\n  lab:\n    scores: {x_baseline: 1.5}\n";
    try {
        load_compare_config(f.string());
        FAIL();
    } catch (const params::ConfigError& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("bad.yaml:3"), std::string::npos) << msg;
        EXPECT_NE(msg.find("reference.lab.scores.x_baseline"), std::string::npos) << msg;
    }
    std::ofstream(f) << "on: [lab:nowhere]\n";
    EXPECT_THROW(load_compare_config(f.string()), params::ConfigError);
    std::ofstream(f) << "colour: red\n";
    EXPECT_THROW(load_compare_config(f.string()), params::ConfigError);
}

// Two sets with a known order: the baseline matches pairs of the tiny lab; x_1D filters every
// keypoint (as in the thesis) and scores 0. A repeated comparison comes from the store.
TEST_F(CompareTest, TwoSetsInKnownOrderWithTauAndStoreReuse) {
    const auto sp = space();
    std::vector<NamedParameterSet> sets{
        {"x_baseline", params::load_parameter_set(source("configs/params/x_baseline.yaml"), sp)},
        {"x_1D", params::load_parameter_set(source("configs/params/x_1D.yaml"), sp)}};
    CompareTarget target = parse_compare_target((root_ / "tiny").string() + ":complete:gt");
    CompareOptions options;
    options.matcher.threads = 2;
    ReferenceColumn ref;
    ref.name = "lab";
    ref.m_star_per_pair = 0.5;
    ref.scores = {{"x_baseline", 0.53}, {"x_1D", 0.0}};
    options.reference = {ref};
    store::ObservationStore db((root_ / "obs.db").string());
    options.db = &db;
    const auto r = compare(sp, sets, {target}, options);
    ASSERT_EQ(r.columns.size(), 1u);
    const auto& col = r.columns[0];
    EXPECT_EQ(col.world, "lab");
    EXPECT_EQ(col.reference_column, "lab");  // found through the dataset's world
    EXPECT_EQ(col.pairs, 6u);
    EXPECT_DOUBLE_EQ(col.settings.m_star, 3.0);  // 0.5 x 6 pairs
    ASSERT_EQ(col.cells.size(), 2u);
    EXPECT_GT(col.cells[0].report.score.m, 0);
    EXPECT_GT(col.cells[0].report.score.p, 0.0);
    EXPECT_EQ(col.cells[1].report.score.m, 0);
    EXPECT_EQ(col.cells[1].report.score.p, 0.0);
    ASSERT_TRUE(col.tau.has_value());
    EXPECT_DOUBLE_EQ(*col.tau, 1.0);
    EXPECT_FALSE(col.cells[0].from_store);
    EXPECT_EQ(db.count(), 2u);

    // Again, with the order of the reference reversed and m* given: answered by the store.
    options.reference[0].scores = {{"x_baseline", 0.1}, {"x_1D", 0.6}};
    target.m_star = 4;
    const auto again = compare(sp, sets, {target}, options);
    const auto& col2 = again.columns[0];
    EXPECT_TRUE(col2.cells[0].from_store);
    EXPECT_TRUE(col2.cells[1].from_store);
    EXPECT_EQ(col2.m_star_rule, "given");
    EXPECT_DOUBLE_EQ(*col2.tau, -1.0);
    EXPECT_EQ(col2.cells[0].report.score.m, col.cells[0].report.score.m);
    EXPECT_EQ(db.count(), 2u);
}

TEST_F(CompareTest, MissingDatasetFailsBeforeAnyEvaluation) {
    std::vector<NamedParameterSet> sets{{"x_baseline", space().defaults()}};
    CompareTarget ok = parse_compare_target((root_ / "tiny").string());
    CompareTarget missing = parse_compare_target((root_ / "nothing").string());
    int evaluations = 0;
    CompareOptions options;
    options.progress = [&](const std::string&) { ++evaluations; };
    EXPECT_THROW(compare(space(), sets, {ok, missing}, options), params::ConfigError);
    EXPECT_EQ(evaluations, 0);
}

}  // namespace
}  // namespace maptune::evaluation
