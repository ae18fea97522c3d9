// `maptune report` on a real tuning run: the data (model, steps, errors, validation) and the
// page as a person sees it — opened in headless Chromium, every figure rendered with the
// right content.
#include "report/report_data.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <numeric>
#include <sstream>

#include "params/yaml_util.hpp"

namespace maptune::report {
namespace {

namespace fs = std::filesystem;
const std::string kSource = MAPTUNE_SOURCE_DIR;
constexpr int kEvaluations = 8;

std::string slurp(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// Runs a shell command line; returns its exit code, output in `out`.
int sh(const std::string& cmd, std::string* out = nullptr, const fs::path& log = "/dev/null") {
    const std::string line = cmd + " >" + log.string() + " 2>&1";
    const int status = std::system(line.c_str());
    if (out) *out = slurp(log);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The children of the first mark group named `name` (`<g class="... name">...</g>`) that
// start with `tag`: one per drawn item of a symbol or rect mark.
int items_in_mark(const std::string& dom, const std::string& name, const std::string& tag) {
    const auto at = dom.find(" role-mark " + name + "\"");
    if (at == std::string::npos) return -1;
    const auto end = dom.find("</g>", at);
    int n = 0;
    for (auto p = dom.find(tag, at); p != std::string::npos && p < end; p = dom.find(tag, p + 1)) ++n;
    return n;
}

int count(const std::string& text, const std::string& what) {
    int n = 0;
    for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
    return n;
}

class ReportTest : public ::testing::Test {
protected:
    // One real run for the suite: 8 evaluations of the PCL matcher on a tiny lab, validated on
    // a held-out one.
    static void SetUpTestSuite() {
        char tmpl[] = "/tmp/maptune_report_test_XXXXXX";
        ASSERT_NE(mkdtemp(tmpl), nullptr);
        root_ = tmpl;
        std::ofstream(root_ / "exp.yaml")
            << "name: reported\nspace: " << kSource << "/configs/spaces/lru_matcher.yaml\n"
            << "dataset: {dir: train, generate: {preset: lab-tiny, runs: 1, submaps: 5, seed: 5}}\n"
            << "view: complete\nmeasure: {m_star: 5}\nbudget: {evaluations: " << kEvaluations << "}\n"
            << "optimizer: {initial_points: 3, seed: 2}\nmatcher: {threads: 2}\n"
            << "start_points: [" << kSource << "/configs/params/x_baseline.yaml]\n"
            << "validate:\n  - label: held\n    dataset: {dir: held, generate: {preset: lab-tiny, runs: 1, "
               "submaps: 4, seed: 9}}\n    m_star: 3\n";
        std::string out;
        const int rc = sh(std::string(MAPTUNE_CLI) + " run --no-progress --experiment " + (root_ / "exp.yaml").string() +
                              " --run-dir " + (root_ / "run").string(),
                          &out, root_ / "run.log");
        ASSERT_EQ(rc, 0) << out;
    }
    static void TearDownTestSuite() { fs::remove_all(root_); }
    static fs::path root_;
};
fs::path ReportTest::root_;

TEST_F(ReportTest, DataHoldsEvaluationsStepsModelAndValidation) {
    ReportOptions options;
    options.slice_points = 20;
    options.grid_points = 12;
    const auto data = report_data({root_ / "run"}, options);
    ASSERT_EQ(data["runs"].size(), 1u);
    const auto& run = data["runs"][0];
    EXPECT_EQ(run["record"]["experiment"], "reported");
    EXPECT_EQ(run["record"]["state"], "finished");
    ASSERT_EQ(run["evaluations"].size(), static_cast<std::size_t>(kEvaluations));
    EXPECT_EQ(run["baseline"], 1);  // the start point goes first
    // Best so far never decreases and ends at the best.
    double best = -1;
    for (const auto& e : run["evaluations"]) {
        ASSERT_FALSE(e["best_so_far"].is_null());
        EXPECT_GE(e["best_so_far"].get<double>(), best);
        best = e["best_so_far"].get<double>();
    }
    // Steps: the baseline, then strictly better sets; every step's errors are its matched pairs.
    const auto& steps = run["steps"];
    ASSERT_GE(steps.size(), 1u);
    EXPECT_EQ(steps[0]["label"], "baseline");
    for (std::size_t i = 0; i < steps.size(); ++i) {
        EXPECT_EQ(steps[i]["errors"].size(), steps[i]["m"].get<std::size_t>()) << steps[i]["label"];
        EXPECT_NEAR(steps[i]["v_share"].get<double>() + steps[i]["eps_share"].get<double>(), steps[i]["p"].get<double>(), 1e-9);
        if (i > 0) {
            EXPECT_GT(steps[i]["p"].get<double>(), steps[i - 1]["p"].get<double>());
        }
    }
    EXPECT_DOUBLE_EQ(steps.back()["p"].get<double>(), best);
    // The refitted model: a slice per parameter, the grid, importance summing to 1.
    const auto& model = run["model"];
    ASSERT_FALSE(model.is_null());
    ASSERT_EQ(model["slices"].size(), 9u);
    for (const auto& s : model["slices"]) {
        EXPECT_GE(s["points"].size(), 2u);
        EXPECT_LE(s["points"].size(), 20u);
        for (const auto& p : s["points"]) EXPECT_GE(p["std"].get<double>(), 0.0);
    }
    EXPECT_NE(model["grid"]["x"], model["grid"]["y"]);
    EXPECT_LE(model["grid"]["cells"].size(), 144u);
    EXPECT_GE(model["grid"]["cells"].size(), 16u);
    double total = 0;
    for (const auto& i : model["importance"]) total += i["importance"].get<double>();
    EXPECT_NEAR(total, 1.0, 1e-9);
    // validation.csv of the run: baseline, best and predicted on the held-out view.
    ASSERT_GE(run["validation"].size(), 2u);
    EXPECT_EQ(run["validation"][0]["set"], "baseline");
    EXPECT_EQ(run["validation"][0]["target"], "held");
    EXPECT_TRUE(run["notes"].empty()) << run["notes"].dump();

    options.grid_x = "r_N";
    options.grid_y = "bogus";
    EXPECT_THROW(report_data({root_ / "run"}, options), params::ConfigError);
    EXPECT_THROW(report_data({root_}, {}), params::ConfigError);  // not a run directory
}

TEST_F(ReportTest, PageRendersEveryFigureInHeadlessChromium) {
    const fs::path out = root_ / "report";
    std::string log;
    ASSERT_EQ(sh(std::string(MAPTUNE_CLI) + " report " + (root_ / "run").string() + " --out " + out.string() +
                     " --grid-points 10",
                 &log, root_ / "report.log"),
              0)
        << log;
    const std::string html = slurp(out / "index.html");
    // Self-contained: the runtime is inlined, nothing is fetched.
    EXPECT_EQ(html.find("<script src"), std::string::npos);
    EXPECT_EQ(html.find("<link "), std::string::npos);
    EXPECT_LT(html.size(), 5u * 1000 * 1000);
    // A log-scaled parameter's axis spans its bounds (r_N: 0.1-2 m), not powers of ten around them.
    EXPECT_NE(html.find(R"("type":"log","domain":[0.1,2],"nice":false)"), std::string::npos);
    for (const char* f : {"history", "progress", "errors", "slices", "grid", "parallel", "importance"}) {
        EXPECT_TRUE(fs::exists(out / "figures" / (std::string(f) + ".svg"))) << f;
    }
    EXPECT_GT(count(slurp(out / "figures" / "history.svg"), "<path"), kEvaluations);

    std::string dom;
    const int rc = sh("chromium --headless --no-sandbox --disable-gpu --user-data-dir=" + (root_ / "chrome").string() +
                          " --virtual-time-budget=20000 --dump-dom file://" + (out / "index.html").string() + " 2>/dev/null",
                      nullptr, root_ / "dom.html");
    ASSERT_EQ(rc, 0) << "chromium failed (bash scripts/install-deps.sh --test installs it)";
    dom = slurp(root_ / "dom.html");
    EXPECT_NE(dom.find("data-figures-done=\"7\""), std::string::npos) << dom.substr(0, 2000);
    EXPECT_EQ(count(dom, "data-rendered=\"yes\""), 7);
    EXPECT_EQ(count(dom, "data-rendered=\"failed\""), 0);
    // History: one point per evaluation, the best-so-far line and the baseline rule.
    EXPECT_EQ(items_in_mark(dom, "history_points_marks", "<path"), kEvaluations);
    EXPECT_EQ(items_in_mark(dom, "history_best_marks", "<path"), 1);
    EXPECT_EQ(items_in_mark(dom, "history_baseline_marks", "<line"), 1);
    // The grid: 10 x 10 cells in each of mean, sigma and acquisition.
    EXPECT_EQ(items_in_mark(dom, "grid_mean_marks", "<path"), 100);
    EXPECT_EQ(items_in_mark(dom, "grid_std_marks", "<path"), 100);
    EXPECT_EQ(items_in_mark(dom, "grid_acquisition_marks", "<path"), 100);
    // A slice band per parameter, one parallel-coordinates line per successful evaluation,
    // an importance bar per parameter.
    EXPECT_EQ(count(dom, " role-mark slice_") / 3, 9);
    EXPECT_EQ(count(dom, "role-mark parallel_lines_marks"), kEvaluations);
    EXPECT_EQ(items_in_mark(dom, "importance_bars_marks", "<path"), 9);
    EXPECT_GE(items_in_mark(dom, "progress_p_marks", "<path"), 2);  // eps and v part of the baseline
    // The validation table and the metadata.
    EXPECT_NE(dom.find("<td>held</td>"), std::string::npos);
    EXPECT_NE(dom.find("lru_matcher"), std::string::npos);
}

TEST_F(ReportTest, BadRunDirectoryIsNamed) {
    std::string log;
    fs::create_directories(root_ / "nothing");
    EXPECT_EQ(sh(std::string(MAPTUNE_CLI) + " report " + (root_ / "nothing").string(), &log, root_ / "bad.log"), 2);
    EXPECT_NE(log.find("nothing: not a run directory"), std::string::npos) << log;
}

}  // namespace
}  // namespace maptune::report
