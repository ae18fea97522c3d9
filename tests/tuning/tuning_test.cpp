// The transport-free tuning core: request identities across restarts, replies checked against
// the set asked for, duplicates and stale answers ignored, failures told as failures, resume,
// budgets and re-sends — the defects of issue 12 that lived in the DDS optimizer's loop.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "params/yaml_util.hpp"
#include "temp_dataset.hpp"
#include "tuning/run_directory.hpp"
#include "tuning/tuning_run.hpp"

namespace maptune {
namespace {

namespace fs = std::filesystem;
using tuning::ReplyOutcome;
const std::string kSource = MAPTUNE_SOURCE_DIR;

class TuningRunTest : public ::testing::Test {
protected:
    void SetUp() override { dir_ = test::make_temp_dir("maptune_tuning_"); }
    void TearDown() override { fs::remove_all(dir_); }

    experiment::Experiment load(const std::string& extra = "",
                                const std::string& optimizer = "optimizer: {seed: 3, initial_points: 2}\n") {
        std::ofstream(dir_ / "baseline.yaml") << "r_N: 0.2\nv_K: 0.1\nt_K: 1.0\nr_D: 0.2\nn_C: 3\nt_C: 0.5\n"
                                                 "r_LRF: 0.2\nv_TF: 0.5\nn_TF: 8\n";
        std::ofstream(dir_ / "exp.yaml") << "name: core\nspace: " << kSource << "/configs/spaces/lru_matcher.yaml\n"
                                         << "dataset: " << (dir_ / "none").string()
                                         << "\nview: complete\nreference: gt\nmeasure: {m_star: 4}\n"
                                         << optimizer
                                         << "start_points: [baseline.yaml]\n" << extra;
        return experiment::load_experiment((dir_ / "exp.yaml").string());
    }

    // p grows with the number of matched pairs; no pairs cannot be scored.
    static measure::Score score(const std::vector<store::PairRecord>& pairs) {
        if (pairs.empty()) throw std::runtime_error("no per-pair results");
        measure::Score s;
        for (const auto& p : pairs) s.m += p.matched ? 1 : 0;
        s.v = static_cast<double>(s.m) / (1.0 + static_cast<double>(s.m));
        s.eps = 0.9;
        s.p = 0.5 * s.v + 0.5 * s.eps;
        return s;
    }

    // Five pairs, the first `matched` of them matched, each taking `seconds`.
    static tuning::Reply answer(const tuning::Request& r, int matched, double seconds = 0) {
        tuning::Reply reply;
        reply.request_id = r.id;
        reply.params = r.params;
        for (int i = 0; i < 5; ++i) {
            store::PairRecord p;
            p.pair_id = "a|" + std::to_string(i);
            p.matched = i < matched;
            p.duration_s = seconds;
            reply.pairs.push_back(p);
        }
        return reply;
    }

    tuning::TuningRun make(const experiment::Experiment& e, const std::string& incarnation, double resend_s = 15) {
        return tuning::TuningRun(e, {"", incarnation, resend_s}, &TuningRunTest::score, 4.0);
    }

    fs::path dir_;
};

TEST_F(TuningRunTest, FirstRequestIsTheStartPointAndIdsCarryTheIncarnation) {
    auto e = load("budget: {evaluations: 5}\n");
    auto run = make(e, "inc1");
    const auto asked = run.ask(1, 0.0);
    ASSERT_EQ(asked.size(), 1u);
    EXPECT_EQ(asked[0].origin, "start");
    EXPECT_EQ(asked[0].id, "core/inc1/1");
    EXPECT_EQ(run.set_key(asked[0].params), run.set_key(e.start_points[0]));
    EXPECT_EQ(run.in_flight(), 1u);
    EXPECT_TRUE(run.ask(1, 0.0).empty()) << "one slot, one request in flight";
}

TEST_F(TuningRunTest, ARestartedRunNeverTakesAnEarlierLifesReply) {
    auto e = load("budget: {evaluations: 6}\n");
    auto first = make(e, "life1");
    auto r1 = first.ask(2, 0.0);
    ASSERT_EQ(r1.size(), 2u);
    tuning::EvaluationRecord rec;
    ASSERT_EQ(first.tell(answer(r1[0], 2), 1.0, &rec), ReplyOutcome::kAccepted);
    EXPECT_EQ(rec.number, 1);

    // The process dies with r1[1] in flight; the restart resumes from the trials file.
    auto second = make(e, "life2");
    second.resume(first.summary().evaluations);
    const auto r2 = second.ask(2, 0.0);
    ASSERT_EQ(r2.size(), 2u);
    std::set<std::string> ids;
    for (const auto& r : r1) ids.insert(r.id);
    for (const auto& r : r2) EXPECT_EQ(ids.count(r.id), 0u) << r.id << " reused after a restart";
    // The late reply of the earlier life — even with a matching set — is not ours.
    auto stale = answer(r1[1], 5);
    EXPECT_EQ(second.tell(stale, 2.0), ReplyOutcome::kNotInFlight);
    EXPECT_EQ(second.summary().evaluations.size(), 1u);
    EXPECT_EQ(second.in_flight(), 2u);
}

TEST_F(TuningRunTest, AReplyForAnotherSetIsIgnoredAndTheRequestStaysInFlight) {
    auto e = load("budget: {evaluations: 5}\n");
    auto run = make(e, "x");
    const auto r = run.ask(1, 0.0).at(0);
    auto foreign = answer(r, 5);
    foreign.params.set("n_TF", foreign.params.get("n_TF") + 7);
    EXPECT_EQ(run.tell(foreign, 1.0), ReplyOutcome::kOtherSet);
    EXPECT_EQ(run.in_flight(), 1u);
    EXPECT_TRUE(run.summary().evaluations.empty());
    tuning::EvaluationRecord rec;
    EXPECT_EQ(run.tell(answer(r, 3), 2.0, &rec), ReplyOutcome::kAccepted);
    EXPECT_EQ(rec.m, 3u);
    EXPECT_DOUBLE_EQ(rec.wall_s, 2.0);
}

TEST_F(TuningRunTest, ADuplicateAnswerCountsOnce) {
    auto e = load("budget: {evaluations: 5}\n");
    auto run = make(e, "x");
    const auto r = run.ask(1, 0.0).at(0);
    EXPECT_EQ(run.tell(answer(r, 3), 1.0), ReplyOutcome::kAccepted);
    EXPECT_EQ(run.tell(answer(r, 3), 1.5), ReplyOutcome::kNotInFlight);
    EXPECT_EQ(run.summary().evaluations.size(), 1u);
}

TEST_F(TuningRunTest, ErrorsAndUnscorableRepliesAreFailedEvaluationsNotTheEnd) {
    auto e = load("budget: {evaluations: 5}\n");
    auto run = make(e, "x");
    auto asked = run.ask(2, 0.0);
    ASSERT_EQ(asked.size(), 2u);
    tuning::Reply error;
    error.request_id = asked[0].id;
    error.ok = false;
    error.error = "no worker serves this space";
    tuning::EvaluationRecord rec;
    ASSERT_EQ(run.tell(error, 1.0, &rec), ReplyOutcome::kAccepted);
    EXPECT_TRUE(rec.failed);
    EXPECT_EQ(rec.error, "no worker serves this space");
    EXPECT_EQ(run.set_key(rec.params), run.set_key(asked[0].params));

    auto broken = answer(asked[1], 0);
    broken.pairs.clear();  // the scorer throws
    ASSERT_EQ(run.tell(broken, 1.0, &rec), ReplyOutcome::kAccepted);
    EXPECT_TRUE(rec.failed);
    EXPECT_NE(rec.error.find("cannot score the reply: no per-pair results"), std::string::npos) << rec.error;
    EXPECT_EQ(run.failed(), 2u);
    EXPECT_EQ(run.summary().best, -1);
    // The run goes on: the model proposes again.
    EXPECT_EQ(run.ask(1, 2.0).size(), 1u);
}

TEST_F(TuningRunTest, BestIsTheHighestSuccessfulScore) {
    auto e = load("budget: {evaluations: 5}\n");
    auto run = make(e, "x");
    const int matched[] = {1, 4, 2};
    for (int m : matched) {
        const auto r = run.ask(1, 0.0).at(0);
        ASSERT_EQ(run.tell(answer(r, m), 1.0), ReplyOutcome::kAccepted);
    }
    ASSERT_EQ(run.summary().best, 1);
    EXPECT_EQ(run.summary().evaluations[1].m, 4u);
    EXPECT_TRUE(run.summary().predicted_best.has_value());
}

TEST_F(TuningRunTest, ResumeRestoresNumberingAndBestWithoutReaskingStartPoints) {
    auto e = load("budget: {evaluations: 4}\n");
    auto first = make(e, "a");
    for (int m : {3, 1}) {
        const auto r = first.ask(1, 0.0).at(0);
        ASSERT_EQ(first.tell(answer(r, m), 1.0), ReplyOutcome::kAccepted);
    }
    // Through the file the restart reads.
    tuning::RunDirectory files(dir_ / "run", e, {"core", "d", "dn", "m", "v", "now"});
    files.write_results(first.summary());
    const auto trials = experiment::read_trials_csv(files.trials_file(), e.space);
    ASSERT_EQ(trials.size(), 2u);
    {  // Issue 14: a NaN p in an edited trials.csv was resumed as the best so far.
        const fs::path edited = dir_ / "edited.csv";
        std::ifstream in(files.trials_file());
        std::string header, row;
        std::getline(in, header);
        std::getline(in, row);
        std::ofstream(edited) << header << "\n" << row.substr(0, row.find(',') + 1) << "nan"
                              << row.substr(row.find(',', row.find(',') + 1)) << "\n";
        try {
            experiment::read_trials_csv(edited, e.space);
            ADD_FAILURE() << "read a NaN p";
        } catch (const params::ConfigError& err) {
            EXPECT_NE(std::string(err.what()).find("edited.csv:2: not a finite number"), std::string::npos) << err.what();
        }
    }

    auto second = make(e, "b");
    second.resume(trials);
    EXPECT_EQ(second.resumed(), 2u);
    EXPECT_EQ(second.summary().best, 0);
    EXPECT_EQ(second.summary().evaluations[0].origin, "start") << "where it came from, kept";
    const auto r = second.ask(1, 0.0).at(0);
    EXPECT_NE(r.origin, "start");
    EXPECT_NE(second.set_key(r.params), second.set_key(e.start_points[0]));
    tuning::EvaluationRecord rec;
    ASSERT_EQ(second.tell(answer(r, 2), 1.0, &rec), ReplyOutcome::kAccepted);
    EXPECT_EQ(rec.number, 3);
}

TEST_F(TuningRunTest, BudgetsEndTheRunAndTheTimeBudgetWaitsForWhatIsInFlight) {
    auto e = load("budget: {evaluations: 3, seconds: 10}\n");
    auto run = make(e, "x");
    EXPECT_FALSE(run.stop_reason(0.0, false));
    EXPECT_EQ(*run.stop_reason(0.0, true), "stopped by signal");
    const auto r = run.ask(1, 0.0).at(0);
    EXPECT_FALSE(run.stop_reason(11.0, false)) << "a request is still in flight";
    EXPECT_TRUE(run.ask(1, 11.0).empty()) << "no new request after the time budget";
    ASSERT_EQ(run.tell(answer(r, 1), 12.0), ReplyOutcome::kAccepted);
    EXPECT_EQ(*run.stop_reason(12.0, false), "time budget used");

    auto count = make(load("budget: {evaluations: 2}\n"), "y");
    const auto asked = count.ask(5, 0.0);
    EXPECT_EQ(asked.size(), 2u) << "never more requests than the evaluation budget";
    for (const auto& a : asked) count.tell(answer(a, 1), 1.0);
    EXPECT_EQ(*count.stop_reason(1.0, false), "evaluation budget used");
}

TEST_F(TuningRunTest, UnansweredRequestsAreResentAfterResendSeconds) {
    auto e = load("budget: {evaluations: 5}\n");
    auto run = make(e, "x", 5.0);
    const auto r = run.ask(1, 0.0).at(0);
    EXPECT_TRUE(run.due_resends(4.0).empty());
    const auto again = run.due_resends(6.0);
    ASSERT_EQ(again.size(), 1u);
    EXPECT_EQ(again[0].id, r.id);
    EXPECT_TRUE(run.due_resends(8.0).empty()) << "re-sent at 6 s, next at 11 s";
    EXPECT_EQ(run.due_resends(11.5).size(), 1u);
    // The wall time of the evaluation counts from the first send.
    tuning::EvaluationRecord rec;
    run.tell(answer(r, 1), 12.0, &rec);
    EXPECT_DOUBLE_EQ(rec.wall_s, 12.0);
}

TEST_F(TuningRunTest, BatchBoundsTheRequestsInFlight) {
    auto free_slots = make(load("budget: {evaluations: 10}\n"), "x");
    EXPECT_EQ(free_slots.ask(4, 0.0).size(), 4u) << "batch 0: one request per free worker slot";
    EXPECT_EQ(free_slots.ask(4, 0.0).size(), 0u);
    auto batch = make(load("budget: {evaluations: 10}\n", "optimizer: {seed: 3, initial_points: 2, batch: 3}\n"), "y");
    EXPECT_EQ(batch.ask(8, 0.0).size(), 3u) << "a batch fixes the requests in flight";
}

}  // namespace
}  // namespace maptune

namespace maptune {
namespace {

// What makes a killed and restarted optimizer indistinguishable from one that never died
// (the fault test compares their trials): the next proposal depends only on the history.
TEST_F(TuningRunTest, AResumedRunProposesWhatTheUninterruptedRunProposed) {
    // Killed in the initial design (after 2 of start + 4 design points) and in the model phase.
    auto e = load("budget: {evaluations: 9}\n", "optimizer: {seed: 3, initial_points: 5}\n");
    auto matched_for = [](const tuning::Request& r) {
        return static_cast<int>(std::lround(r.params.get("n_C") + 10 * r.params.get("t_C"))) % 6;
    };
    auto through_file = [&](const tuning::TuningRun& run) {
        tuning::RunDirectory files(dir_ / "run", e, {"core", "d", "dn", "m", "v", "now"});
        files.write_results(run.summary());
        return experiment::read_trials_csv(files.trials_file(), e.space);
    };
    auto whole = make(e, "one-life");
    std::vector<std::string> keys;
    for (int i = 0; i < 9; ++i) {
        const auto r = whole.ask(1, i).at(0);
        keys.push_back(whole.set_key(r.params));
        ASSERT_EQ(whole.tell(answer(r, matched_for(r)), i + 0.5), ReplyOutcome::kAccepted);
    }
    // Killed after 2, then after 5 (with a request in flight each time), restarted each time.
    std::vector<tuning::EvaluationRecord> trials;
    std::vector<std::string> resumed_keys;
    for (const int stop : {2, 5, 9}) {
        auto life = make(e, "life-" + std::to_string(stop));
        life.resume(trials);
        while (static_cast<int>(life.summary().evaluations.size()) < stop) {
            const auto r = life.ask(1, 0).at(0);
            resumed_keys.push_back(life.set_key(r.params));
            life.tell(answer(r, matched_for(r)), 1);
        }
        if (stop < 9) life.ask(1, 2);  // in flight when killed: never answered
        trials = through_file(life);
    }
    EXPECT_EQ(resumed_keys, keys);
}

}  // namespace
}  // namespace maptune

namespace maptune {
namespace {

TEST_F(TuningRunTest, WithARunTimeBudgetTheBestIsTheBestWithinIt) {
    for (const bool budget : {false, true}) {
        auto e = load("budget: {evaluations: 5}\n");
        e.max_pair_seconds = budget ? 0.5 : 0;  // parsing: ARunTimeBudgetIsReadAndABadOneNamesTheKey
        auto run = make(e, "x");
        // 4 matches at 2 s per pair (4x over), then 3 matches at 0.4 s per pair.
        const auto slow = run.ask(1, 0.0).at(0);
        ASSERT_EQ(run.tell(answer(slow, 4, 2.0), 1.0), ReplyOutcome::kAccepted);
        const auto fast = run.ask(1, 0.0).at(0);
        ASSERT_EQ(run.tell(answer(fast, 3, 0.4), 1.0), ReplyOutcome::kAccepted);
        const auto& s = run.summary();
        EXPECT_DOUBLE_EQ(s.evaluations[0].pair_s, 2.0);
        EXPECT_GT(s.evaluations[0].p, s.evaluations[1].p) << "p itself is the thesis's, untouched";
        EXPECT_EQ(s.best, budget ? 1 : 0);
        EXPECT_DOUBLE_EQ(experiment::record_objective(e, s.evaluations[0]),
                         budget ? s.evaluations[0].p / 16 : s.evaluations[0].p);
        EXPECT_DOUBLE_EQ(experiment::record_objective(e, s.evaluations[1]), s.evaluations[1].p);
        // The seconds per pair survive the run directory, and so does the best on resume.
        tuning::RunDirectory files(dir_ / (budget ? "b" : "n"), e, {"core", "d", "dn", "m", "v", "now"});
        files.write_results(s);
        const auto trials = experiment::read_trials_csv(files.trials_file(), e.space);
        ASSERT_EQ(trials.size(), 2u);
        EXPECT_DOUBLE_EQ(trials[0].pair_s, 2.0);
        auto resumed = make(e, "y");
        resumed.resume(trials);
        EXPECT_EQ(resumed.summary().best, budget ? 1 : 0);
    }
}

TEST_F(TuningRunTest, TrialsWrittenBeforeThePairSecondsColumnResume) {
    auto e = load();
    std::string header = "evaluation,p,m,v,eps,failed,from_store,wall_s,origin";
    std::string row = "1,0.7,3,0.8,0.6,0,0,1.5,start";
    for (const auto& spec : e.space.specs()) {
        header += "," + spec.name;
        row += "," + params::format_double(e.start_points[0].get(spec.name));
    }
    std::ofstream(dir_ / "old.csv") << header << ",error\n" << row << ",\n";
    const auto trials = experiment::read_trials_csv(dir_ / "old.csv", e.space);
    ASSERT_EQ(trials.size(), 1u);
    EXPECT_EQ(trials[0].origin, "start");
    EXPECT_DOUBLE_EQ(trials[0].pair_s, 0.0);
    EXPECT_DOUBLE_EQ(trials[0].p, 0.7);
}

TEST_F(TuningRunTest, ARunTimeBudgetIsReadAndABadOneNamesTheKey) {
    auto write = [&](const std::string& budget) {
        std::ofstream(dir_ / "t.yaml") << "name: t\nspace: " << kSource << "/configs/spaces/lru_matcher.yaml\n"
                                       << "dataset: " << (dir_ / "none").string()
                                       << "\nmeasure: {m_star: 4, max_pair_seconds: " << budget << "}\n";
        return (dir_ / "t.yaml").string();
    };
    EXPECT_DOUBLE_EQ(experiment::load_experiment(write("0.25")).max_pair_seconds, 0.25);
    for (const char* bad : {"-1", "0", "nan", "fast"}) {
        try {
            experiment::load_experiment(write(bad));
            ADD_FAILURE() << "accepted max_pair_seconds " << bad;
        } catch (const params::ConfigError& err) {
            EXPECT_NE(std::string(err.what()).find("max_pair_seconds"), std::string::npos) << err.what();
        }
    }
}

}  // namespace
}  // namespace maptune
