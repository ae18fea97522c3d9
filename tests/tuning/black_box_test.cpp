// maptune optimize's core (issue 15): objective commands — output parsing, failures, timeouts
// that stop everything a command started, parallel slots — and a whole black-box run that
// finds a known minimum, writes its run directory and resumes.
#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

#include "experiment/run_files.hpp"
#include "params/yaml_util.hpp"
#include "temp_dataset.hpp"
#include "tuning/black_box.hpp"
#include "tuning/command_objective.hpp"

namespace maptune {
namespace {

namespace fs = std::filesystem;
using tuning::CommandPool;
using tuning::parse_objective_output;

double now_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Polls the pool until `n` commands finished or `limit_s` passed.
std::map<std::string, tuning::ObjectiveResult> collect(CommandPool& pool, std::size_t n, double limit_s = 20) {
    std::map<std::string, tuning::ObjectiveResult> out;
    const double end = now_s() + limit_s;
    while (out.size() < n && now_s() < end) {
        for (auto& [tag, r] : pool.poll(0.2)) out[tag] = r;
    }
    return out;
}

TEST(ObjectiveOutput, NumberOrJsonOnTheLastLine) {
    auto r = parse_objective_output("building...\nprogress 50%\n  -1.25e-3 \n\n");
    ASSERT_TRUE(r.ok) << r.error;
    EXPECT_DOUBLE_EQ(r.value, -1.25e-3);
    r = parse_objective_output("{\"value\": 7, \"reason\": \"ignored when ok\"}\n");
    ASSERT_TRUE(r.ok) << r.error;
    EXPECT_DOUBLE_EQ(r.value, 7);
    r = parse_objective_output("{\"failed\": true, \"reason\": \"diverged\"}");
    EXPECT_FALSE(r.ok);
    EXPECT_NE(r.error.find("diverged"), std::string::npos);
    r = parse_objective_output("{\"failed\": false, \"value\": 0.5}");
    EXPECT_TRUE(r.ok);
    EXPECT_DOUBLE_EQ(r.value, 0.5);
    for (const std::string bad : {"", "\n\n", "done", "nan", "inf", "{\"value\": \"1\"}", "{\"failed\": 1}", "[1]",
                                  "0.5 metres"}) {
        r = parse_objective_output(bad);
        EXPECT_FALSE(r.ok) << "'" << bad << "'";
        EXPECT_FALSE(r.error.empty());
    }
    // The message quotes what was read.
    EXPECT_NE(parse_objective_output("done\n").error.find("'done'"), std::string::npos);
}

TEST(CommandPool, InputEnvironmentExitStatusAndSignals) {
    CommandPool pool(
        "read line; case \"$TAG\" in ok) echo \"$line\" | sed 's/.*\"x\": *\\([0-9.]*\\).*/\\1/';; "
        "bad) echo 'missing file' >&2; exit 3;; sig) kill -9 $$;; esac",
        10, 3);
    EXPECT_EQ(pool.free_slots(), 3);
    pool.start("a", "{\"x\": 0.75}\n", {{"TAG", "ok"}});
    pool.start("b", "{\"x\": 1}\n", {{"TAG", "bad"}});
    pool.start("c", "{\"x\": 1}\n", {{"TAG", "sig"}});
    EXPECT_EQ(pool.free_slots(), 0);
    const auto done = collect(pool, 3);
    ASSERT_EQ(done.size(), 3u);
    EXPECT_TRUE(done.at("a").ok) << done.at("a").error;
    EXPECT_DOUBLE_EQ(done.at("a").value, 0.75);
    EXPECT_FALSE(done.at("b").ok);
    EXPECT_NE(done.at("b").error.find("status 3"), std::string::npos) << done.at("b").error;
    EXPECT_NE(done.at("b").error.find("missing file"), std::string::npos) << done.at("b").error;
    EXPECT_FALSE(done.at("c").ok);
    EXPECT_NE(done.at("c").error.find("signal 9"), std::string::npos) << done.at("c").error;
    EXPECT_EQ(pool.running(), 0);
}

TEST(CommandPool, TimeoutStopsTheWholeProcessGroup) {
    const fs::path dir = test::make_temp_dir("maptune_cmdpool_");
    const fs::path pid_file = dir / "child.pid";
    // The command starts a background child that would outlive a plain kill of the shell.
    CommandPool pool("sleep 60 & echo $! > '" + pid_file.string() + "'; wait", 0.5, 1);
    const double t0 = now_s();
    pool.start("slow", "", {});
    const auto done = collect(pool, 1);
    ASSERT_EQ(done.size(), 1u);
    EXPECT_LT(now_s() - t0, 10.0);
    EXPECT_FALSE(done.at("slow").ok);
    EXPECT_NE(done.at("slow").error.find("timeout"), std::string::npos) << done.at("slow").error;
    int child = 0;
    std::ifstream(pid_file) >> child;
    ASSERT_GT(child, 0);
    // Reaped by init once killed: poll until it is gone.
    bool gone = false;
    for (int i = 0; i < 100 && !gone; ++i) {
        gone = ::kill(child, 0) != 0;
        if (!gone) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    EXPECT_TRUE(gone) << "the command's background child " << child << " survived the timeout";
    fs::remove_all(dir);
}

TEST(CommandPool, RunsAtMostParallelAtOnce) {
    const fs::path dir = test::make_temp_dir("maptune_cmdpool_");
    // Each command records the number of commands running beside it.
    const std::string cmd = "d='" + dir.string() + "'; touch \"$d/run.$TAG\"; sleep 0.3; ls \"$d\" | grep -c '^run\\.' "
                            "> \"$d/seen.$TAG\"; rm \"$d/run.$TAG\"; echo 1";
    CommandPool pool(cmd, 10, 2);
    int started = 0, finished = 0;
    const double end = now_s() + 30;
    while (finished < 6 && now_s() < end) {
        while (pool.free_slots() > 0 && started < 6) {
            pool.start(std::to_string(started), "", {{"TAG", std::to_string(started)}});
            ++started;
        }
        for (auto& [tag, r] : pool.poll(0.2)) {
            EXPECT_TRUE(r.ok) << tag << ": " << r.error;
            ++finished;
        }
    }
    ASSERT_EQ(finished, 6);
    int max_seen = 0;
    for (int i = 0; i < 6; ++i) {
        int n = 0;
        std::ifstream(dir / ("seen." + std::to_string(i))) >> n;
        max_seen = std::max(max_seen, n);
    }
    EXPECT_EQ(max_seen, 2);
    fs::remove_all(dir);
}

class BlackBoxRun : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = test::make_temp_dir("maptune_blackbox_");
        std::ofstream(dir_ / "space.yaml")
            << "name: toy\nparameters:\n"
               "  x: {type: float, low: -2.0, high: 3.0, default: 2.5}\n"
               "  k: {type: int, low: 1, high: 5, default: 4}\n";
        // (x − 0.7)² + (k − 2)², minimum 0 at x = 0.7, k = 2; k = 5 fails.
        std::ofstream(dir_ / "objective.sh")
            << "#!/bin/sh\nread line\n"
               "x=$(echo \"$line\" | sed 's/.*\"x\": *\\([-0-9.e]*\\).*/\\1/')\n"
               "k=$(echo \"$line\" | sed 's/.*\"k\": *\\([0-9]*\\).*/\\1/')\n"
               "[ \"$k\" = 5 ] && { echo 'k = 5 is not supported' >&2; exit 2; }\n"
               "awk -v x=\"$x\" -v k=\"$k\" 'BEGIN { printf \"%.9g\\n\", (x - 0.7)^2 + (k - 2)^2 }'\n";
        fs::permissions(dir_ / "objective.sh", fs::perms::owner_all);
    }
    void TearDown() override { fs::remove_all(dir_); }

    tuning::BlackBoxSpec spec(int budget) const {
        tuning::BlackBoxSpec s;
        s.name = "toy";
        s.space_file = (dir_ / "space.yaml").string();
        s.command = "'" + (dir_ / "objective.sh").string() + "'";
        s.minimize = true;
        s.budget = budget;
        s.parallel = 2;
        s.timeout_s = 20;
        s.seed = 5;
        return s;
    }

    fs::path dir_;
};

TEST_F(BlackBoxRun, FindsTheMinimumWritesTheRunAndResumes) {
    const fs::path run_dir = dir_ / "run";
    std::ostringstream log;
    const auto file = tuning::write_black_box_experiment(run_dir, spec(20));
    auto e = experiment::load_experiment(file);
    ASSERT_TRUE(e.objective);
    EXPECT_TRUE(e.minimize);
    const auto first = tuning::run_black_box(e, run_dir, log, [] { return false; });
    ASSERT_EQ(first.evaluations.size(), 20u) << log.str();
    ASSERT_GE(first.best, 0);
    const auto& best = first.evaluations[static_cast<std::size_t>(first.best)];
    EXPECT_LT(best.p, 0.05) << log.str();
    EXPECT_EQ(best.params.get("k"), 2);
    for (const auto& r : first.evaluations) {
        if (r.params.get("k") == 5) {
            EXPECT_TRUE(r.failed);
            EXPECT_NE(r.error.find("not supported"), std::string::npos) << r.error;
        }
        if (!r.failed) {
            EXPECT_GE(r.p, best.p);  // minimized: the best is the smallest
        }
    }
    for (const char* f : {"trials.csv", "best_params.yaml", "run.yaml", "experiment.yaml", "space.yaml"}) {
        EXPECT_TRUE(fs::exists(run_dir / f)) << f;
    }
    const auto record = experiment::read_run_record(run_dir);
    EXPECT_EQ(record.state, "finished");
    ASSERT_TRUE(record.best_p);
    EXPECT_DOUBLE_EQ(*record.best_p, best.p);
    const auto best_file = params::load_yaml_file((run_dir / "best_params.yaml").string());
    EXPECT_DOUBLE_EQ(best_file["x"].as<double>(), best.params.get("x"));

    // The same command line with a larger budget resumes: 20 kept, 5 new.
    EXPECT_THROW(tuning::write_black_box_experiment(run_dir, [&] {
                     auto other = spec(25);
                     other.command = "echo 1";
                     return other;
                 }()),
                 params::ConfigError);
    e = experiment::load_experiment(tuning::write_black_box_experiment(run_dir, spec(20)));
    e.max_evaluations = 25;
    std::ostringstream log2;
    const auto second = tuning::run_black_box(e, run_dir, log2, [] { return false; });
    EXPECT_NE(log2.str().find("resumed 20 evaluations"), std::string::npos) << log2.str();
    ASSERT_EQ(second.evaluations.size(), 25u);
    for (std::size_t i = 0; i < 20; ++i) {
        EXPECT_EQ(second.evaluations[i].p, first.evaluations[i].p);
    }
    EXPECT_EQ(experiment::read_trials_csv(run_dir / "trials.csv", e.space).size(), 25u);
    EXPECT_EQ(experiment::read_run_record(run_dir).space_hash, e.space.hash());
    EXPECT_EQ(log2.str().find("another design space"), std::string::npos) << log2.str();

    // Resumed in a space whose file changed since (k now log-scaled): said, then resumed.
    e.space = params::ParameterSpace::parse(
        "name: toy\nparameters:\n"
        "  x: {type: float, low: -2.0, high: 3.0, default: 2.5}\n"
        "  k: {type: int, low: 1, high: 5, default: 4, log_scale: true}\n",
        "changed.yaml");
    e.max_evaluations = 26;
    std::ostringstream log3;
    const auto third = tuning::run_black_box(e, run_dir, log3, [] { return false; });
    EXPECT_NE(log3.str().find("run.yaml: the run started in another design space"), std::string::npos) << log3.str();
    EXPECT_NE(log3.str().find("resumed 25 evaluations"), std::string::npos) << log3.str();
    EXPECT_EQ(third.evaluations.size(), 26u);
    EXPECT_EQ(experiment::read_run_record(run_dir).space_hash, e.space.hash());
}

TEST_F(BlackBoxRun, StopEndsRunningCommandsAndKeepsTheResults) {
    auto s = spec(50);
    s.command = "sleep 0.2; echo 1";
    const fs::path run_dir = dir_ / "run";
    const auto e = experiment::load_experiment(tuning::write_black_box_experiment(run_dir, s));
    std::ostringstream log;
    const double t0 = now_s();
    const auto summary = tuning::run_black_box(e, run_dir, log, [&] { return now_s() - t0 > 1.0; });
    EXPECT_EQ(summary.stop_reason, "stopped by signal");
    EXPECT_GT(summary.evaluations.size(), 0u);
    EXPECT_LT(summary.evaluations.size(), 50u);
    EXPECT_EQ(experiment::read_trials_csv(run_dir / "trials.csv", e.space).size(), summary.evaluations.size());
}

TEST_F(BlackBoxRun, ExperimentFileErrorsNameTheKey) {
    auto write = [&](const std::string& text) {
        std::ofstream(dir_ / "exp.yaml") << "name: t\nspace: space.yaml\n" << text;
        return (dir_ / "exp.yaml").string();
    };
    auto error = [&](const std::string& text) {
        try {
            experiment::load_experiment(write(text));
        } catch (const params::ConfigError& err) {
            return std::string(err.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(error("objective: {command: 'echo 1', direction: sideways}\n").find("objective.direction"),
              std::string::npos);
    EXPECT_NE(error("objective: {command: 'echo 1'}\ndataset: d\n").find("does not apply"), std::string::npos);
    EXPECT_NE(error("objective: {direction: minimize}\n").find("command"), std::string::npos);
    EXPECT_NE(error("objective: {command: 'echo 1', parallel: 0}\n").find("objective.parallel"), std::string::npos);
    const auto e = experiment::load_experiment(write("objective: {command: 'echo 1', timeout_s: 3, parallel: 4}\n"));
    ASSERT_TRUE(e.objective);
    EXPECT_EQ(e.objective->parallel, 4);
    EXPECT_DOUBLE_EQ(e.objective->timeout_s, 3);
    EXPECT_FALSE(e.minimize);
    EXPECT_EQ(tuning::parameters_json(e, e.fixed), "{\"x\": 2.5, \"k\": 4}\n");
}

}  // namespace
}  // namespace maptune
