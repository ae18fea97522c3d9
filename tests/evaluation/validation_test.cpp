#include "evaluation/validation.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "params/yaml_util.hpp"
#include "temp_dataset.hpp"

namespace maptune::evaluation {
namespace {

namespace fs = std::filesystem;
const std::string kSource = MAPTUNE_SOURCE_DIR;

std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string l; std::getline(in, l);) out.push_back(l);
    return out;
}

class ValidationTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = test::make_temp_dir("maptune_validation_test_");
        fs::copy(kSource + "/configs/spaces/lru_matcher.yaml", dir_ / "space.yaml");
        fs::copy(kSource + "/configs/params/x_baseline.yaml", dir_ / "x_baseline.yaml");
        run_ = dir_ / "run";
        fs::create_directories(run_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    experiment::Experiment write_experiment(const std::string& validate) {
        std::ofstream(dir_ / "exp.yaml") << "name: v\nspace: space.yaml\ndataset: train\n"
                                            "start_points: [x_baseline.yaml]\n"
                                         << validate;
        return experiment::load_experiment((dir_ / "exp.yaml").string());
    }
    fs::path dir_, run_;
};

// The held-out view is generated on first use; the baseline matches, "best" (x_1D: every
// keypoint filtered) scores 0, "predicted" equals the baseline and comes from the store; a
// second validation evaluates nothing.
TEST_F(ValidationTest, ScoresBaselineBestAndPredictedOnAGeneratedHeldOutView) {
    const auto e = write_experiment(
        "validate:\n  - label: held\n    dataset: {dir: held, generate: {preset: lab-tiny, runs: 1, "
        "submaps: 4, seed: 7}}\n    m_star: 3\n");
    fs::copy(kSource + "/configs/params/x_1D.yaml", run_ / "best_params.yaml");
    fs::copy(kSource + "/configs/params/x_baseline.yaml", run_ / "predicted_best.yaml");
    const auto sets = validation_sets(e, run_);
    ASSERT_EQ(sets.size(), 3u);
    EXPECT_EQ(sets[0].name, kBaselineSet);
    EXPECT_EQ(sets[1].name, kBestSet);
    EXPECT_EQ(sets[2].name, kPredictedSet);

    store::ObservationStore db((dir_ / "obs.db").string());
    CompareOptions options;
    options.matcher = experiment_matcher_settings(e, 2);
    options.db = &db;
    std::vector<std::string> log;
    options.progress = [&](const std::string& line) { log.push_back(line); };
    const CompareResult r = validate(e, sets, options);
    EXPECT_TRUE(fs::exists(dir_ / "held" / "manifest.yaml"));
    ASSERT_FALSE(log.empty());
    EXPECT_NE(log.front().find("generating dataset"), std::string::npos) << log.front();
    ASSERT_EQ(r.columns.size(), 1u);
    const auto& col = r.columns[0];
    EXPECT_EQ(col.target.label, "held");
    EXPECT_DOUBLE_EQ(col.settings.m_star, 3);
    EXPECT_DOUBLE_EQ(col.settings.e_star, e.e_star);
    const double base = col.cells[0].report.score.p, best = col.cells[1].report.score.p;
    EXPECT_GT(base, 0);
    EXPECT_EQ(best, 0);
    EXPECT_DOUBLE_EQ(col.cells[2].report.score.p, base);
    EXPECT_FALSE(col.cells[0].from_store);
    EXPECT_TRUE(col.cells[2].from_store);

    const auto csv = lines(validation_csv(r));
    ASSERT_EQ(csv.size(), 4u);
    EXPECT_EQ(csv[0].rfind("set,target,dataset_id,view,reference,pairs,m_star,p,", 0), 0u) << csv[0];
    EXPECT_EQ(csv[1].rfind("baseline,held,", 0), 0u) << csv[1];
    EXPECT_NE(csv[1].find(",complete,gt,6," + params::format_double(3.0) + ","), std::string::npos) << csv[1];
    EXPECT_NE(csv[1].find("," + params::format_double(0.0) + ",0"), std::string::npos) << csv[1];
    EXPECT_NE(csv[2].find("," + params::format_double(-base) + ",0"), std::string::npos) << csv[2];
    EXPECT_EQ(csv[3].back(), '1');  // predicted: from the store

    const CompareResult again = validate(e, sets, options);
    for (const auto& c : again.columns[0].cells) EXPECT_TRUE(c.from_store);
    EXPECT_DOUBLE_EQ(again.columns[0].cells[0].report.score.p, base);
}

TEST_F(ValidationTest, ErrorsNameWhatIsMissing) {
    const auto none = write_experiment("");
    fs::copy(kSource + "/configs/params/x_baseline.yaml", run_ / "best_params.yaml");
    try {
        validate(none, validation_sets(none, run_), {});
        FAIL();
    } catch (const params::ConfigError& err) {
        EXPECT_NE(std::string(err.what()).find("no 'validate' section"), std::string::npos) << err.what();
    }
    fs::remove(run_ / "best_params.yaml");
    try {
        validation_sets(none, run_);
        FAIL();
    } catch (const params::ConfigError& err) {
        EXPECT_NE(std::string(err.what()).find("best_params.yaml: missing"), std::string::npos) << err.what();
    }
    // No dataset and nothing to generate it from: named, before any matching.
    const auto absent = write_experiment("validate: [{dataset: nowhere}]\n");
    fs::copy(kSource + "/configs/params/x_baseline.yaml", run_ / "best_params.yaml");
    try {
        validate(absent, validation_sets(absent, run_), {});
        FAIL();
    } catch (const params::ConfigError& err) {
        EXPECT_NE(std::string(err.what()).find("nowhere: no dataset there"), std::string::npos) << err.what();
    }
}

// An existing directory is used only when it is what dataset.generate makes: a dataset of
// another seed (or an older preset) is refused, naming the setting, and left untouched.
TEST_F(ValidationTest, AnExistingDatasetOfOtherSettingsIsRefused) {
    const std::string dir = (dir_ / "held").string();
    experiment::GenerateSpec spec{"lab-tiny", 1, 2, 7, {}};
    ensure_dataset(dir, spec, {});
    const std::string id = dataset::Dataset::open(dir).manifest().id;
    ensure_dataset(dir, spec, {});  // the same settings: used as it is
    spec.seed = 8;
    try {
        ensure_dataset(dir, spec, {});
        FAIL();
    } catch (const params::ConfigError& err) {
        EXPECT_NE(std::string(err.what()).find("seed: the dataset has 7, the settings ask for 8"), std::string::npos)
            << err.what();
        EXPECT_NE(std::string(err.what()).find(dir), std::string::npos) << err.what();
    }
    spec = {"lab", 1, 2, 7, {}};  // another preset: many settings differ
    try {
        ensure_dataset(dir, spec, {});
        FAIL();
    } catch (const params::ConfigError& err) {
        EXPECT_NE(std::string(err.what()).find("more)"), std::string::npos) << err.what();
    }
    spec = {"lab-tiny", 1, 2, 7, {{"worlds", "2", ""}}};  // a simulator setting on top of the preset
    try {
        ensure_dataset(dir, spec, {});
        FAIL();
    } catch (const params::ConfigError& err) {
        EXPECT_NE(std::string(err.what()).find("worlds: the dataset has 1, the settings ask for 2"), std::string::npos)
            << err.what();
    }
    spec.sim = {{"wolds", "2", "exp.yaml:9: dataset.generate.sim.wolds"}};
    try {
        ensure_dataset((dir_ / "other").string(), spec, {});
        FAIL();
    } catch (const params::ConfigError& err) {
        EXPECT_NE(std::string(err.what()).find("exp.yaml:9: dataset.generate.sim.wolds: --sim: unknown simulator setting 'wolds'"),
                  std::string::npos)
            << err.what();
    }
    EXPECT_FALSE(fs::exists(dir_ / "other"));
    EXPECT_EQ(dataset::Dataset::open(dir).manifest().id, id);
}

// matcher.settings reach the matcher settings (and so the matcher version every worker must
// announce); a bad one names file, line and key.
TEST_F(ValidationTest, ExperimentMatcherSettingsAndTheirErrors) {
    auto plain = write_experiment("");
    auto e = write_experiment("matcher:\n  total_time_limit_s: 900\n  settings: {min_ransac_inliers: 8, lrf_method: board}\n");
    const auto s = experiment_matcher_settings(e);
    EXPECT_EQ(s.min_ransac_inliers, 8);
    EXPECT_EQ(s.lrf_method, matcher::LrfMethod::kBoard);
    EXPECT_DOUBLE_EQ(s.total_time_limit_s, 900);
    EXPECT_NE(matcher_version(s), matcher_version(experiment_matcher_settings(plain)));
    // Without a matcher section the experiment's matcher is the matcher's own default: the
    // version a worker started without --experiment announces (they share observations).
    EXPECT_EQ(matcher_version(experiment_matcher_settings(plain)), matcher_version(matcher::MatcherSettings{}));
    auto bad = write_experiment("matcher:\n  settings:\n    min_ransac_inliers: lots\n");
    try {
        experiment_matcher_settings(bad);
        FAIL() << "accepted a bad matcher setting";
    } catch (const params::ConfigError& err) {
        EXPECT_NE(std::string(err.what()).find("exp.yaml:7: matcher.settings.min_ransac_inliers: "), std::string::npos)
            << err.what();
    }
}

// A report of `matched` pairs with translation errors `e_t` (d 1 m) and `unmatched` more pairs.
scoring::ScoreReport report_of(const std::vector<double>& e_t, std::size_t unmatched, double m_star) {
    scoring::ScoreReport r;
    r.settings = {0.4, m_star, 0.5};
    std::vector<measure::MatchError> errors;
    for (double e : e_t) {
        scoring::PairScore ps;
        ps.matched = true;
        ps.e_t = e;
        ps.d = 1;
        r.per_pair.push_back(ps);
        errors.push_back({e, 0, 1});
    }
    r.per_pair.resize(r.per_pair.size() + unmatched);
    r.pairs = r.per_pair.size();
    r.matched = e_t.size();
    r.score = measure::score(errors, r.settings);
    return r;
}

// The pooled column scores each set on the union of the targets' pairs (m* summed), which is
// not the mean of its p on the targets; targets of different views are not pooled.
TEST(PooledColumnTest, EachSetScoredOnTheUnionOfTheTargets) {
    CompareResult r;
    r.set_names = {kBaselineSet, kBestSet};
    for (double m_star : {4.0, 6.0}) {
        CompareColumn col;
        col.target.label = "t" + std::to_string(r.columns.size());
        col.pairs = 10;
        col.settings = {0.4, m_star, 0.5};
        r.columns.push_back(col);
    }
    // baseline: 3 good matches on the first target, 6 poor ones on the second; best: 2 + 2 good.
    r.columns[0].cells = {{report_of({0.05, 0.1, 0.1}, 7, 4), true, 0, {}}, {report_of({0.05, 0.05}, 8, 4), true, 0, {}}};
    r.columns[1].cells = {{report_of({0.35, 0.3, 0.3, 0.3, 0.32, 0.38}, 4, 6), false, 2.5, {}},
                          {report_of({0.1, 0.1}, 8, 6), true, 0, {}}};
    add_pooled_column(r);
    ASSERT_EQ(r.columns.size(), 3u);
    const CompareColumn& pooled = r.columns[2];
    EXPECT_EQ(pooled.target.label, kPooledTarget);
    EXPECT_EQ(pooled.pairs, 20u);
    EXPECT_DOUBLE_EQ(pooled.settings.m_star, 10.0);
    const measure::MeasureSettings all{0.4, 10, 0.5};
    std::vector<measure::MatchError> base;
    for (double e : {0.05, 0.1, 0.1, 0.35, 0.3, 0.3, 0.3, 0.32, 0.38}) base.push_back({e, 0, 1});
    EXPECT_DOUBLE_EQ(pooled.cells[0].report.score.p, measure::score(base, all).p);
    EXPECT_EQ(pooled.cells[0].report.score.m, 9u);
    EXPECT_FALSE(pooled.cells[0].from_store);  // one part was evaluated
    EXPECT_DOUBLE_EQ(pooled.cells[0].wall_seconds, 2.5);
    EXPECT_TRUE(pooled.cells[1].from_store);
    const double mean_p = 0.5 * (r.columns[0].cells[0].report.score.p + r.columns[1].cells[0].report.score.p);
    EXPECT_GT(std::abs(pooled.cells[0].report.score.p - mean_p), 0.01);
    // The CSV has a row per set for it.
    const auto csv = validation_csv(r);
    EXPECT_NE(csv.find("\nbest,pooled,pooled,"), std::string::npos) << csv;

    CompareResult single = r;
    single.columns.resize(1);
    add_pooled_column(single);
    EXPECT_EQ(single.columns.size(), 1u);
    CompareResult mixed = r;
    mixed.columns.resize(2);
    mixed.columns[1].target.view = dataset::View::subsequent;
    add_pooled_column(mixed);
    EXPECT_EQ(mixed.columns.size(), 2u);
}

TEST(SeedSummaryTest, MedianMinMaxAndSpreadOverSeeds) {
    const Spread s = spread({0.7, 0.5, 0.6, 0.9});
    EXPECT_EQ(s.n, 4);
    EXPECT_DOUBLE_EQ(s.median, 0.65);
    EXPECT_DOUBLE_EQ(s.min, 0.5);
    EXPECT_DOUBLE_EQ(s.max, 0.9);
    EXPECT_DOUBLE_EQ(spread({0.3, 0.1, 0.2}).median, 0.2);
    EXPECT_EQ(spread({}).n, 0);

    // Two seeds without validation, one without a best: empty cells, statistics over what is there.
    std::vector<SeedOutcome> seeds{{1, "runs/x/seed-1", 0.5, std::nullopt},
                                   {2, "runs/x/seed-2", 0.7, std::nullopt},
                                   {3, "runs/x/seed-3", std::nullopt, std::nullopt}};
    const auto csv = lines(seeds_summary_csv(seeds));
    ASSERT_EQ(csv.size(), 8u);
    EXPECT_EQ(csv[0], "seed,best_p,run_dir");
    EXPECT_EQ(csv[1], "1," + params::format_double(0.5) + ",seed-1");
    EXPECT_EQ(csv[3], "3,,seed-3");
    EXPECT_EQ(csv[4], "median," + params::format_double(0.6) + ",");
    EXPECT_EQ(csv[7], "spread," + params::format_double(0.7 - 0.5) + ",");
}

}  // namespace
}  // namespace maptune::evaluation
