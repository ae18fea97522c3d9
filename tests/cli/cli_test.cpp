// Runs the real maptune executable as a user would and checks its output and exit codes.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "test_domain.hpp"
#include "store/observation_store.hpp"

namespace {

namespace fs = std::filesystem;

struct CliRun {
    int exit_code = -1;
    std::string out, err;
};

class CliTest : public ::testing::Test {
protected:
    void SetUp() override {
        char tmpl[] = "/tmp/maptune_cli_test_XXXXXX";
        ASSERT_NE(mkdtemp(tmpl), nullptr);
        dir_ = tmpl;
    }
    void TearDown() override { fs::remove_all(dir_); }

    static std::string slurp(const fs::path& p) {
        std::ifstream in(p);
        std::stringstream s;
        s << in.rdbuf();
        return s.str();
    }

    // Runs `maptune args` in the source dir (so default config paths resolve) with `input`
    // on standard input.
    CliRun maptune(const std::string& args, const std::string& input = "") {
        const fs::path in = dir_ / "stdin", out = dir_ / "stdout", err = dir_ / "stderr";
        std::ofstream(in) << input;
        const std::string cmd = std::string("cd ") + MAPTUNE_SOURCE_DIR + " && " + MAPTUNE_CLI +
                                " " + args + " <" + in.string() + " >" + out.string() + " 2>" +
                                err.string();
        const int status = std::system(cmd.c_str());
        CliRun r;
        r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        r.out = slurp(out);
        r.err = slurp(err);
        return r;
    }

    fs::path dir_;
};

TEST_F(CliTest, ScoreMatchesSpecFormula) {
    const CliRun r = maptune("score",
                          R"({"e_star": 0.4, "m_star": 60, "w_v": 0.5, "matches": [)"
                          R"({"e_t": 0.05, "e_r": 0.0, "d": 5.0}, {"e_t": 0.2, "e_r": 0.0, "d": 5.0}]})");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["m"], 2);
    const double v = 2.0 / (60.0 / 9.0 + 2.0);
    const double eps = (0.95 + 0.78053) / 2.0;
    EXPECT_NEAR(j["v"].get<double>(), v, 1e-12);
    EXPECT_NEAR(j["eps"].get<double>(), eps, 1e-5);
    EXPECT_NEAR(j["p"].get<double>(), 0.5 * v + 0.5 * eps, 1e-5);
}

TEST_F(CliTest, ScoreReadsAFileAndDefaultsSettings) {
    std::ofstream(dir_ / "m.json") << R"({"matches": []})";
    const CliRun r = maptune("score " + (dir_ / "m.json").string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["p"].get<double>(), 0.0);
    EXPECT_EQ(j["e_star"].get<double>(), 0.4);
    EXPECT_EQ(j["w_v"].get<double>(), 0.5);
}

TEST_F(CliTest, ScoreRejectsBadInputWithExitCode2) {
    struct Case {
        std::string input, fragment;
    };
    for (const Case& c : std::vector<Case>{
             {"{not json", "invalid JSON"},
             {R"({"matches": [{"e_t": "x", "e_r": 0, "d": 1}]})", "matches[0].e_t: expected a number"},
             {R"({"matches": [{"e_t": 0.1, "d": 1}]})", "matches[0].e_r: missing"},
             {R"({"matches": [{"e_t": -1, "e_r": 0, "d": 1}]})", "matches[0].e_t must be"},
             {R"({"e_star": 0.01, "matches": []})", "e_star must be"},
             {R"({"m_star": 0, "matches": []})", "m_star must be"},
             {R"({"matches": {}})", "'matches' must be an array"},
             {R"({"matchez": []})", "unknown key 'matchez'"},
             {R"([1, 2])", "expected a JSON object"},
             // Issue 14: a deeply nested value segfaulted while its error message dumped it.
             {R"({"matches": [{"e_t": )" + std::string(100000, '[') + std::string(100000, ']') +
                  R"(, "e_r": 0, "d": 1}]})",
              "matches[0].e_t: expected a number, got array"},
         }) {
        const CliRun r = maptune("score", c.input);
        EXPECT_EQ(r.exit_code, 2) << c.input.substr(0, 200);
        EXPECT_NE(r.err.find(c.fragment), std::string::npos) << c.input.substr(0, 200) << " → " << r.err;
        EXPECT_TRUE(r.out.empty());
    }
    const CliRun missing = maptune("score /nonexistent.json");
    EXPECT_EQ(missing.exit_code, 2);
    EXPECT_NE(missing.err.find("/nonexistent.json: cannot open"), std::string::npos);
}

TEST_F(CliTest, TrialsListsStoredObservationsInEveryFormat) {
    const std::string db = (dir_ / "obs.db").string();
    {
        maptune::store::ObservationStore store(db);
        for (int i = 0; i < 3; ++i) {
            maptune::store::Observation o;
            o.key = {"ds1", i == 2 ? "subsequent" : "complete", "lru_matcher", "1", "k" + std::to_string(i)};
            o.params.set("r_N", 0.2 + 0.1 * i);
            o.params.set("n_TF", 8);
            maptune::store::PairRecord p;
            p.pair_id = "run00/0-1";
            p.matched = i > 0;
            o.pairs = {p, p};
            o.pairs[1].status = maptune::store::PairStatus::kTimeout;
            o.wall_seconds = 1.25;
            store.put(o);
        }
    }
    const CliRun json = maptune("trials --db " + db + " -f json");
    ASSERT_EQ(json.exit_code, 0) << json.err;
    const auto rows = nlohmann::json::parse(json.out);
    ASSERT_EQ(rows.size(), 3u);
    EXPECT_EQ(rows[1]["view"], "complete");
    EXPECT_EQ(rows[1]["matched"], 2);
    EXPECT_EQ(rows[1]["timeout"], 1);
    EXPECT_NEAR(rows[1]["r_N"].get<double>(), 0.3, 1e-12);
    EXPECT_EQ(rows[2]["pairs"], 2);

    const CliRun csv = maptune("trials --db " + db + " -f csv --view subsequent");
    ASSERT_EQ(csv.exit_code, 0);
    EXPECT_EQ(csv.out.rfind("id,created,dataset,view,matcher,pairs,matched,failed,timeout,wall_s,n_TF,r_N\n", 0), 0u)
        << csv.out;
    EXPECT_EQ(std::count(csv.out.begin(), csv.out.end(), '\n'), 2);

    const CliRun table = maptune("trials --db " + db);
    ASSERT_EQ(table.exit_code, 0);
    EXPECT_NE(table.out.find("lru_matcher/1"), std::string::npos);

    const CliRun none = maptune("trials --db " + (dir_ / "absent.db").string());
    EXPECT_EQ(none.exit_code, 2);
    EXPECT_NE(none.err.find("no such file"), std::string::npos);
    EXPECT_FALSE(fs::exists(dir_ / "absent.db"));  // never created by a read-only command

    std::ofstream(dir_ / "foreign.db") << "hello";
    const CliRun foreign = maptune("trials --db " + (dir_ / "foreign.db").string());
    EXPECT_EQ(foreign.exit_code, 2);
    EXPECT_NE(foreign.err.find("not an SQLite database"), std::string::npos);
}

TEST_F(CliTest, ParamsExportKeyAndShow) {
    const CliRun ros = maptune("params export --params configs/params/x_9D_ssgt1.yaml --node matcher");
    ASSERT_EQ(ros.exit_code, 0) << ros.err;
    EXPECT_NE(ros.out.find("matcher:\n  ros__parameters:\n"), std::string::npos);
    EXPECT_NE(ros.out.find("    r_D: 2.0\n"), std::string::npos) << ros.out;
    EXPECT_NE(ros.out.find("    n_TF: 63\n"), std::string::npos);

    const CliRun key = maptune("params key --params configs/params/x_2D.yaml");
    ASSERT_EQ(key.exit_code, 0);
    EXPECT_EQ(key.out, "n_C=3;n_TF=8;r_D=0.34;r_LRF=0.20;r_N=0.20;t_C=0.50;t_K=0.95;v_K=0.10;v_TF=0.50\n");

    const CliRun show = maptune("params show");
    ASSERT_EQ(show.exit_code, 0);
    EXPECT_NE(show.out.find("n_TF"), std::string::npos);

    std::ofstream(dir_ / "bad.yaml") << "r_N: 0.2\nn_C: 11\n";
    const CliRun bad = maptune("params key --params " + (dir_ / "bad.yaml").string());
    EXPECT_EQ(bad.exit_code, 2);
    EXPECT_NE(bad.err.find("bad.yaml:2: n_C: n_C: 11.0 is outside [1.0, 10.0]"), std::string::npos)
        << bad.err;
}

TEST_F(CliTest, HelpAndUsageErrors) {
    const CliRun help = maptune("--help");
    EXPECT_EQ(help.exit_code, 0);
    EXPECT_NE(help.out.find("score"), std::string::npos);
    const CliRun bad = maptune("trials --format xml --db x.db");
    EXPECT_EQ(bad.exit_code, 2);
#ifdef MAPTUNE_CLI_HAS_EVALUATION
    // Issue 14: time limits of 0, negative or NaN were accepted (every pair then timed out).
    for (const char* limit : {"--pair-time-limit 0", "--time-limit -5", "--pair-time-limit nan"}) {
        const CliRun r = maptune(std::string("evaluate --dataset /tmp ") + limit);
        EXPECT_EQ(r.exit_code, 2) << limit;
        EXPECT_NE(r.err.find("time-limit"), std::string::npos) << limit << " → " << r.err;
    }
    // Every float option: CLI::Range let NaN through.
    const CliRun wait = maptune("run --experiment configs/experiments/demo.yaml --wait nan");
    EXPECT_EQ(wait.exit_code, 2);
    EXPECT_NE(wait.err.find("'nan' is not a finite number"), std::string::npos) << wait.err;
#endif
}

#ifdef MAPTUNE_CLI_HAS_EVALUATION
// `maptune run --seeds` with a validate: section on a generated held-out view: one run
// directory per seed with its run record and validation.csv, summary.csv over the seeds;
// `maptune validate` on the same directory answers everything from the shared store.
// Issue 14: filesystem errors outside a command's own checks ended `run` with std::terminate
// (exit 134) and a listing turned an empty file into a store.
TEST_F(CliTest, FilesystemErrorsAreMessagesAndListingNeverWrites) {
    const std::string src = MAPTUNE_SOURCE_DIR;
    std::ofstream(dir_ / "exp.yaml") << "name: fs\nspace: " << src << "/configs/spaces/lru_matcher.yaml\n"
                                     << "dataset: {dir: d, generate: {preset: lab-tiny, runs: 1, submaps: 2, seed: 5}}\n";
    std::ofstream(dir_ / "a_file") << "x";
    const CliRun under_file = maptune("run --experiment " + (dir_ / "exp.yaml").string() + " --run-dir " +
                                      (dir_ / "a_file" / "run").string() + " --no-progress");
    EXPECT_EQ(under_file.exit_code, 1) << under_file.err;
    EXPECT_NE(under_file.err.find("a_file/run"), std::string::npos) << under_file.err;
    std::ofstream(dir_ / "empty.db").close();
    const CliRun listing = maptune("trials --db " + (dir_ / "empty.db").string());
    EXPECT_EQ(listing.exit_code, 2) << listing.err;
    EXPECT_NE(listing.err.find("empty file"), std::string::npos) << listing.err;
    EXPECT_EQ(fs::file_size(dir_ / "empty.db"), 0u);
#ifdef MAPTUNE_CLI_HAS_EVALUATION
    // A sweep whose output cannot be written fails before it evaluates anything (it exited 0).
    const CliRun gen = maptune("dataset generate --preset lab-tiny --runs 1 --submaps 2 --out " + (dir_ / "sweep_d").string());
    ASSERT_EQ(gen.exit_code, 0) << gen.err;
    const CliRun sweep = maptune("sweep --dataset " + (dir_ / "sweep_d").string() + " --param t_K --steps 2 -o /nonexistent/x.csv");
    EXPECT_EQ(sweep.exit_code, 2) << sweep.out << sweep.err;
    EXPECT_NE(sweep.err.find("/nonexistent/x.csv: cannot write"), std::string::npos) << sweep.err;
#endif
}

#ifdef MAPTUNE_CLI_HAS_EVALUATION
// Issue 14: an interrupted generate left its temporary <out>.tmp-PID-N directory behind.
TEST_F(CliTest, InterruptedGenerateLeavesNothingBehind) {
    const fs::path out = dir_ / "gen";
    // Started in the background, interrupted once its temporary directory exists (polled, 5 s at most).
    const std::string script = std::string(MAPTUNE_CLI) + " dataset generate --preset lab --runs 6 --submaps 10 --seed 3 " +
                               "--threads 1 --out " + out.string() + " >/dev/null 2>" + (dir_ / "gen.err").string() +
                               " & pid=$!; for i in $(seq 1 100); do ls -d " + out.string() +
                               ".tmp-* >/dev/null 2>&1 && break; sleep 0.05; done; kill -INT $pid; wait $pid";
    const int status = std::system(("bash -c '" + script + "'").c_str());
    EXPECT_NE(WEXITSTATUS(status), 0);
    EXPECT_NE(slurp(dir_ / "gen.err").find("interrupted: nothing written"), std::string::npos) << slurp(dir_ / "gen.err");
    for (const auto& e : fs::directory_iterator(dir_))
        EXPECT_EQ(e.path().filename().string().rfind("gen", 0) == 0 && e.path().filename() != "gen.err", false)
            << "left behind: " << e.path();
}
#endif

TEST_F(CliTest, RunWithSeedsValidatesOnHeldOutViewsAndValidateReusesTheStore) {
    const std::string src = MAPTUNE_SOURCE_DIR;
    std::ofstream(dir_ / "exp.yaml")
        << "name: seeded\nspace: " << src << "/configs/spaces/lru_matcher.yaml\n"
        << "dataset: {dir: train, generate: {preset: lab-tiny, runs: 1, submaps: 4, seed: 5}}\n"
        << "view: complete\nmeasure: {m_star_per_pair: 0.5}\nbudget: {evaluations: 3}\n"  // 6 pairs: m* 3
        << "optimizer: {initial_points: 1}\nmatcher: {threads: 2}\n"
        << "start_points: [" << src << "/configs/params/x_baseline.yaml]\n"
        << "validate:\n  - label: held\n    dataset: {dir: held, generate: {preset: lab-tiny, runs: 1, "
           "submaps: 4, seed: 8}}\n    m_star: 3\n";
    const fs::path root = dir_ / "runs";
    // A domain no other test process holds (the run's own pick is random in 1..200).
    const CliRun run = maptune("run --domain " + std::to_string(maptune::test::reserve_domain()) + " --experiment " +
                               (dir_ / "exp.yaml").string() + " --run-dir " +
                               root.string() + " --seeds 1,2 --no-progress");
    ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
    for (const char* seed : {"seed-1", "seed-2"}) {
        for (const char* f : {"run.yaml", "trials.csv", "best_params.yaml", "validation.csv"}) {
            EXPECT_TRUE(fs::exists(root / seed / f)) << seed << "/" << f;
        }
        const std::string record = slurp(root / seed / "run.yaml");
        EXPECT_NE(record.find("experiment_file: " + (dir_ / "exp.yaml").string()), std::string::npos) << record;
        EXPECT_NE(record.find("state: finished"), std::string::npos) << record;
        EXPECT_NE(record.find("evaluations: 3"), std::string::npos) << record;
        EXPECT_NE(record.find("m_star: 3.0\n"), std::string::npos) << record;
        EXPECT_NE(record.find("m_star_rule: per_pair"), std::string::npos) << record;
        const std::string v = slurp(root / seed / "validation.csv");
        EXPECT_NE(v.find("\nbaseline,held,"), std::string::npos) << v;
        EXPECT_NE(v.find("\nbest,held,"), std::string::npos) << v;
    }
    EXPECT_TRUE(fs::exists(dir_ / "held" / "manifest.yaml"));
    // The matcher behind DDS (worker, sample_db) gives what it gives in-process: the
    // baseline's p in the run equals `maptune evaluate`'s.
    {
        std::istringstream trials(slurp(root / "seed-1" / "trials.csv"));
        std::string line;
        std::getline(trials, line);
        std::getline(trials, line);  // evaluation 1: the start point
        const double run_p = std::stod(line.substr(line.find(',') + 1));
        const CliRun ev = maptune("evaluate --dataset " + (dir_ / "train").string() +
                                  " --view complete --params configs/params/x_baseline.yaml --m-star 3 --threads 2");
        ASSERT_EQ(ev.exit_code, 0) << ev.err;
        const auto at = ev.out.find("\np ");
        ASSERT_NE(at, std::string::npos) << ev.out;
        EXPECT_NEAR(std::stod(ev.out.substr(at + 3)), run_p, 1e-4) << ev.out;
    }
    EXPECT_TRUE(fs::exists(root / "observations.db"));
    EXPECT_FALSE(fs::exists(root / "seed-1" / "observations.db"));  // one store for all seeds
    const std::string summary = slurp(root / "summary.csv");
    EXPECT_EQ(summary.rfind("seed,best_p,baseline@held,best@held", 0), 0u) << summary;
    EXPECT_NE(summary.find("\nspread,"), std::string::npos) << summary;
    EXPECT_NE(run.out.find("over 2 seeds"), std::string::npos) << run.out;
    EXPECT_NE(run.out.find("held p - baseline"), std::string::npos) << run.out;
#ifdef MAPTUNE_CLI_HAS_REPORT
    // The report of all seeds: the band over the runs and one section per seed.
    const std::string page = slurp(root / "report" / "index.html");
    EXPECT_NE(page.find("history_band"), std::string::npos);
    EXPECT_NE(page.find("Over 2 runs"), std::string::npos);
#endif

    // Listed by run: only what seed 2 evaluated, scored as the run scored it.
    const CliRun listed = maptune("trials --db " + (root / "observations.db").string() + " --run-dir " +
                                  (root / "seed-2").string() + " -f json");
    ASSERT_EQ(listed.exit_code, 0) << listed.err;
    const auto seed2 = nlohmann::json::parse(listed.out);
    EXPECT_EQ(seed2.size(), 3u) << listed.out;  // 3 evaluations, all different sets
    const auto all = nlohmann::json::parse(maptune("trials --db " + (root / "observations.db").string() + " -f json").out);
    EXPECT_GT(all.size(), seed2.size());  // the other seed's and the held-out view's too
    double best_listed = 0;
    for (const auto& row : seed2) best_listed = std::max(best_listed, row["p"].get<double>());
    const std::string record = slurp(root / "seed-2" / "run.yaml");
    const auto at = record.find("\n  p: ");
    ASSERT_NE(at, std::string::npos) << record;
    EXPECT_NEAR(best_listed, std::stod(record.substr(at + 6)), 1e-4);

    const CliRun again = maptune("validate --run-dir " + root.string() + " -f csv");
    ASSERT_EQ(again.exit_code, 0) << again.err;
    EXPECT_EQ(again.err.find("generating"), std::string::npos) << again.err;
    std::istringstream csv(slurp(root / "seed-2" / "validation.csv"));
    std::string line;
    std::getline(csv, line);
    int rows = 0;
    while (std::getline(csv, line)) {
        ++rows;
        EXPECT_EQ(line.back(), '1') << "evaluated again: " << line;
    }
    EXPECT_GE(rows, 2);

    const CliRun single = maptune("validate --run-dir " + (root / "seed-1").string());
    ASSERT_EQ(single.exit_code, 0) << single.err;
    EXPECT_NE(single.out.find("| baseline"), std::string::npos) << single.out;

    fs::create_directories(dir_ / "empty");
    const CliRun bad = maptune("validate --run-dir " + (dir_ / "empty").string());
    EXPECT_EQ(bad.exit_code, 2);
    EXPECT_NE(bad.err.find("run.yaml: missing"), std::string::npos) << bad.err;
}

// `maptune run --budget` overrides the experiment's evaluations, and a larger one on the same
// run directory extends the finished run with exactly what an uninterrupted run would have done.
TEST_F(CliTest, RunBudgetOverridesAndExtendsAFinishedRun) {
    const std::string src = MAPTUNE_SOURCE_DIR;
    std::ofstream(dir_ / "exp.yaml") << "name: budget\nspace: " << src << "/configs/spaces/lru_matcher.yaml\n"
                                     << "dataset: {dir: d, generate: {preset: lab-tiny, runs: 1, submaps: 3, seed: 5}}\n"
                                     << "view: complete\nbudget: {evaluations: 20}\noptimizer: {seed: 3}\n";
    auto run = [&](const std::string& run_dir, int budget) {
        // No --domain: the run leases a random one no other maptune process holds.
        return maptune("run --analytic --no-progress --no-report --experiment " + (dir_ / "exp.yaml").string() +
                       " --run-dir " + (dir_ / run_dir).string() + " --budget " + std::to_string(budget));
    };
    // The rows without their timing columns (wall_s, pair_s, elapsed_s differ from run to run).
    auto rows = [&](const std::string& run_dir) {
        std::istringstream in(slurp(dir_ / run_dir / "trials.csv"));
        std::vector<std::string> out;
        for (std::string line; std::getline(in, line);) {
            std::vector<std::string> cells;
            std::stringstream cs(line);
            for (std::string c; std::getline(cs, c, ',');) cells.push_back(c);
            std::string kept;
            for (std::size_t i = 0; i < cells.size(); ++i)
                if (i != 7 && i != 8 && i != 10) kept += cells[i] + ",";
            out.push_back(kept);
        }
        return out;
    };
    const CliRun four = run("a", 4);
    ASSERT_EQ(four.exit_code, 0) << four.out << four.err;
    EXPECT_EQ(rows("a").size(), 5u);  // header + 4
    EXPECT_NE(slurp(dir_ / "a" / "run.yaml").find("budget:\n  evaluations: 4"), std::string::npos);
    const CliRun more = run("a", 7);
    ASSERT_EQ(more.exit_code, 0) << more.out << more.err;
    EXPECT_NE((more.out + more.err).find("resumed 4 evaluations"), std::string::npos) << more.out << more.err;
    const CliRun whole = run("b", 7);
    ASSERT_EQ(whole.exit_code, 0) << whole.out << whole.err;
    EXPECT_EQ(rows("a").size(), 8u);
    EXPECT_EQ(rows("a"), rows("b"));
    EXPECT_EQ((more.out + more.err).find("another design space"), std::string::npos) << more.out << more.err;

    // The space file changed since (its scales linear again): resuming says so, then goes on.
    std::string space = slurp(fs::path(src) / "configs/spaces/lru_matcher.yaml");
    for (std::size_t at; (at = space.find("log_scale: true, ")) != std::string::npos;) space.erase(at, 17);
    std::ofstream(dir_ / "linear.yaml") << space;
    std::string exp = slurp(dir_ / "exp.yaml");
    const std::string shipped = src + "/configs/spaces/lru_matcher.yaml";
    exp.replace(exp.find(shipped), shipped.size(), (dir_ / "linear.yaml").string());
    std::ofstream(dir_ / "exp.yaml") << exp;
    const CliRun changed = run("a", 8);
    ASSERT_EQ(changed.exit_code, 0) << changed.out << changed.err;
    EXPECT_NE((changed.out + changed.err).find("run.yaml: the run started in another design space"), std::string::npos)
        << changed.out << changed.err;
    EXPECT_NE((changed.out + changed.err).find("resumed 7 evaluations"), std::string::npos) << changed.out << changed.err;
    EXPECT_EQ(rows("a").size(), 9u);
    const CliRun bad = maptune("run --experiment " + (dir_ / "exp.yaml").string() + " --budget 0");
    EXPECT_EQ(bad.exit_code, 2) << bad.out << bad.err;
    EXPECT_NE(bad.err.find("--budget"), std::string::npos) << bad.err;
}

// `maptune compare` end to end on a tiny simulated lab: two sets in a known order (x_1D
// filters every keypoint), Table 5.2 layout in markdown with the reference column and tau,
// JSON, and a second run answered from the store.
TEST_F(CliTest, CompareTwoSetsTableJsonAndStore) {
    const std::string ds = (dir_ / "tiny").string();
    const CliRun gen = maptune("dataset generate --preset lab-tiny --runs 1 --submaps 4 --seed 5 --out " + ds);
    ASSERT_EQ(gen.exit_code, 0) << gen.err;
    std::ofstream(dir_ / "ref.yaml") << "reference:\n  lab:\n    m_star_per_pair: 0.5\n"
                                        "    scores: {x_baseline: 0.53, x_1D: 0.0}\n";
    const std::string common = "compare --params configs/params/x_baseline.yaml configs/params/x_1D.yaml --on small=" +
                               ds + ":complete:gt --reference-scores " + (dir_ / "ref.yaml").string() +
                               " --db " + (dir_ / "obs.db").string() + " --threads 2";
    const CliRun md = maptune(common);
    ASSERT_EQ(md.exit_code, 0) << md.err;
    EXPECT_NE(md.out.find("| set "), std::string::npos) << md.out;
    EXPECT_NE(md.out.find("small p"), std::string::npos) << md.out;
    EXPECT_NE(md.out.find("small ref p"), std::string::npos) << md.out;
    EXPECT_NE(md.out.find("| kendall_tau"), std::string::npos) << md.out;
    EXPECT_NE(md.out.find("Kendall's tau-b vs reference 'lab': 1.00"), std::string::npos) << md.out;
    EXPECT_NE(md.out.find("m* 3.0"), std::string::npos) << md.out;  // 0.5 x 6 pairs
    EXPECT_NE(md.out.find("2 evaluated"), std::string::npos) << md.out;

    const CliRun js = maptune(common + " --format json");
    ASSERT_EQ(js.exit_code, 0) << js.err;
    const auto j = nlohmann::json::parse(js.out);
    ASSERT_EQ(j["views"].size(), 1u);
    const auto& v = j["views"][0];
    EXPECT_EQ(v["label"], "small");
    EXPECT_EQ(v["pairs"], 6);
    EXPECT_DOUBLE_EQ(v["kendall_tau"].get<double>(), 1.0);
    ASSERT_EQ(v["sets"].size(), 2u);
    EXPECT_EQ(v["sets"][0]["set"], "x_baseline");
    EXPECT_TRUE(v["sets"][0]["from_store"].get<bool>());
    EXPECT_GT(v["sets"][0]["p"].get<double>(), v["sets"][1]["p"].get<double>());
    EXPECT_EQ(v["sets"][1]["m"], 0);

    const CliRun csv = maptune(common + " --format csv");
    ASSERT_EQ(csv.exit_code, 0) << csv.err;
    EXPECT_EQ(csv.out.rfind("set,small p,small m,", 0), 0u) << csv.out;

    // The same store through `trials`: scored with the same m*, the best set first; removal
    // and import between stores.
    const std::string db = (dir_ / "obs.db").string();
    const CliRun best = maptune("trials --db " + db + " --score-on " + ds + " --m-star 3 --best 1 -f json");
    ASSERT_EQ(best.exit_code, 0) << best.err;
    const auto rows = nlohmann::json::parse(best.out);
    ASSERT_EQ(rows.size(), 1u);
    EXPECT_NEAR(rows[0]["p"].get<double>(), v["sets"][0]["p"].get<double>(), 1e-4);
    EXPECT_EQ(rows[0]["m"], v["sets"][0]["m"]);
    EXPECT_NEAR(rows[0]["v_K"].get<double>(), 0.1, 1e-12);  // x_baseline
    const CliRun by_p = maptune("trials --db " + db + " --score-on " + ds + " --sort p -f csv");
    ASSERT_EQ(by_p.exit_code, 0) << by_p.err;
    EXPECT_NE(by_p.out.find(",p,m,eps,v,"), std::string::npos) << by_p.out;
    EXPECT_EQ(maptune("trials --db " + db + " --best 1").exit_code, 2);  // needs --score-on

    const std::string copy = (dir_ / "copy.db").string();
    const CliRun imp = maptune("trials --db " + copy + " --import " + db);
    ASSERT_EQ(imp.exit_code, 0) << imp.err;
    EXPECT_NE(imp.out.find("imported 2 of 2"), std::string::npos) << imp.out;
    const CliRun again = maptune("trials --db " + copy + " --import " + db);
    EXPECT_NE(again.out.find("imported 0 of 2 observations"), std::string::npos) << again.out;
    const std::string id = std::to_string(rows[0]["id"].get<int>());
    const CliRun rm = maptune("trials --db " + copy + " --remove " + id);
    ASSERT_EQ(rm.exit_code, 0) << rm.err;
    EXPECT_EQ(maptune("trials --db " + copy + " --remove " + id).exit_code, 2);  // gone
    const auto left = nlohmann::json::parse(maptune("trials --db " + copy + " -f json").out);
    EXPECT_EQ(left.size(), 1u);

    const CliRun bad = maptune("compare --params configs/params/x_baseline.yaml --on " + ds + ":sideways");
    EXPECT_EQ(bad.exit_code, 2);
    EXPECT_NE(bad.err.find("sideways"), std::string::npos) << bad.err;
    const CliRun bad_setting = maptune("compare --params configs/params/x_baseline.yaml --on " + ds +
                                       " --no-db --matcher min_ransac_inliers=-3");
    EXPECT_EQ(bad_setting.exit_code, 2);
    EXPECT_NE(bad_setting.err.find("min_ransac_inliers"), std::string::npos) << bad_setting.err;
}
#endif

}  // namespace

// maptune optimize (issue 15): a command as the objective, minimized, with a failing region;
// the run directory is written and an existing one resumes.
TEST_F(CliTest, OptimizeRunsACommandObjectiveAndResumes) {
    std::ofstream(dir_ / "obj.sh") << "read set\n"
                                      "t=$(echo \"$set\" | sed 's/.*\"t_C\": *\\([-0-9.e]*\\).*/\\1/')\n"
                                      "awk -v t=\"$t\" 'BEGIN { if (t > 0.9) exit 5; printf \"%.6f\\n\", (t - 0.3)^2 }'\n";
    const std::string run = (dir_ / "run").string();
    const std::string args = "optimize --space configs/spaces/lru_matcher.yaml --optimize t_C --minimize --budget 12 "
                             "--seed 2 --parallel 2 --timeout 30 --objective-cmd 'sh " + (dir_ / "obj.sh").string() +
                             "' --run-dir " + run;
    CliRun r = maptune(args);
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    EXPECT_NE(r.out.find("evaluation 12/12"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("best: value"), std::string::npos) << r.out;
    const std::string trials = slurp(fs::path(run) / "trials.csv");
    EXPECT_EQ(std::count(trials.begin(), trials.end(), '\n'), 13);
    const std::string best = slurp(fs::path(run) / "best_params.yaml");
    EXPECT_NE(best.find("value = "), std::string::npos) << best;
    EXPECT_NE(slurp(fs::path(run) / "run.yaml").find("direction: minimize"), std::string::npos);

    // Resuming with the run's own experiment file and a larger budget in the file.
    std::string exp = slurp(fs::path(run) / "experiment.yaml");
    exp.replace(exp.find("evaluations: 12"), 15, "evaluations: 14");
    std::ofstream(fs::path(run) / "experiment.yaml") << exp;
    r = maptune("optimize --experiment " + run + "/experiment.yaml --run-dir " + run);
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    EXPECT_NE(r.out.find("resumed 12 evaluations"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("evaluation 14/14"), std::string::npos) << r.out;

    // A matcher experiment is not a black box; a missing objective is a usage error.
    r = maptune("optimize --experiment configs/experiments/demo.yaml");
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find("no 'objective'"), std::string::npos) << r.err;
    r = maptune("optimize --space configs/spaces/lru_matcher.yaml");
    EXPECT_EQ(r.exit_code, 2);
}
