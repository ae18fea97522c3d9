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


// Multi-fidelity (issue 16 item 2): after the start point, proposals go to the subset view; one
// that cannot beat the best stops there (its estimate told to the model, never the best), one
// that can goes on to the whole view under a new request id, its time counted from the first.
class FidelityTest : public TuningRunTest {
protected:
    static constexpr std::size_t kView = 400, kSubset = 100;
    static constexpr double kRating = 0.9;

    // p of the measure with every match rated kRating.
    static measure::Score real_score(const std::vector<store::PairRecord>& pairs) {
        std::vector<measure::MatchError> errors;
        const double e_t = 0.4 - std::log(2 / (1 - kRating) - 1) / (std::log(39.0) / 0.35);  // eps_t(e_t) = kRating
        for (const auto& p : pairs) {
            if (p.matched) errors.push_back({e_t, 0, 1});
        }
        return measure::score(errors, {0.4, 100, 0.5});
    }
    // The subset is every 4th pair of the view ("a|0", "a|4", ...); its outcomes in that order.
    static std::vector<double> outcomes(const std::vector<store::PairRecord>& pairs) {
        std::vector<double> out(kSubset, std::nan(""));
        for (const auto& p : pairs) {
            const std::size_t i = std::stoul(p.pair_id.substr(2));
            if (i % 4 == 0 && i / 4 < kSubset && p.matched) out[i / 4] = kRating;
        }
        return out;
    }
    // n pairs "a|0", "a|stride", ...; the first `matched` of them matched.
    static tuning::Reply answer_n(const tuning::Request& r, std::size_t n, std::size_t matched, std::size_t stride = 1) {
        tuning::Reply reply;
        reply.request_id = r.id;
        reply.params = r.params;
        for (std::size_t i = 0; i < n; ++i) {
            store::PairRecord p;
            p.pair_id = "a|" + std::to_string(i * stride);
            p.matched = i < matched;
            p.duration_s = 0.1;
            reply.pairs.push_back(p);
        }
        return reply;
    }
    tuning::TuningRun make_mf(const experiment::Experiment& e) {
        tuning::TuningOptions o{"", "mf", 15, tuning::Fidelity{"complete/4", kSubset, kView, &FidelityTest::outcomes}};
        return tuning::TuningRun(e, o, &FidelityTest::real_score, 100);
    }
};

TEST_F(FidelityTest, HopelessProposalsStopOnTheSubsetAndPromisingOnesGoOn) {
    auto e = load("fidelity: {subset: 4}\nbudget: {evaluations: 5}\n");
    ASSERT_EQ(e.fidelity_subset, 4);
    auto run = make_mf(e);
    const auto start = run.ask(1, 0.0).at(0);
    EXPECT_EQ(start.view, "complete") << "the start point is always judged on the whole view";
    tuning::EvaluationRecord rec;
    ASSERT_EQ(run.tell(answer_n(start, kView, 200), 1.0, &rec), ReplyOutcome::kAccepted);
    EXPECT_EQ(rec.fidelity, 1);
    const double incumbent = rec.p;

    // No match on the subset, where the best matched half: cannot beat the best.
    const auto hopeless = run.ask(1, 2.0).at(0);
    EXPECT_EQ(hopeless.view, "complete/4");
    ASSERT_EQ(run.tell(answer_n(hopeless, kSubset, 0, 4), 3.0, &rec), ReplyOutcome::kAccepted);
    EXPECT_EQ(rec.fidelity, 4);
    EXPECT_DOUBLE_EQ(rec.p, 0.0);
    EXPECT_EQ(run.summary().best, 0);

    // The same pairs matched as the best did: it may beat it, so the whole view is asked.
    const auto promising = run.ask(1, 4.0).at(0);
    ASSERT_EQ(promising.view, "complete/4");
    EXPECT_EQ(run.tell(answer_n(promising, kSubset, 50, 4), 5.0), ReplyOutcome::kContinued);
    EXPECT_EQ(run.in_flight(), 1u);
    EXPECT_EQ(run.summary().evaluations.size(), 2u);
    const auto asked = run.ask(1, 5.0);
    ASSERT_EQ(asked.size(), 1u) << "only the whole-view request: the slot is still taken";
    const auto whole = asked[0];
    EXPECT_EQ(whole.view, "complete");
    EXPECT_NE(whole.id, promising.id);
    EXPECT_EQ(run.set_key(whole.params), run.set_key(promising.params));
    EXPECT_EQ(run.tell(answer_n(promising, kSubset, 50, 4), 5.5), ReplyOutcome::kNotInFlight);
    ASSERT_EQ(run.tell(answer_n(whole, kView, 300), 9.0, &rec), ReplyOutcome::kAccepted);
    EXPECT_EQ(rec.fidelity, 1);
    EXPECT_GT(rec.p, incumbent);
    EXPECT_DOUBLE_EQ(rec.wall_s, 5.0) << "both stages of the proposal";
    EXPECT_DOUBLE_EQ(rec.elapsed_s, 9.0);
    EXPECT_EQ(run.summary().best, 2);

    // The run directory keeps the fidelity; a resumed run has the same best and goes on in time,
    // after recalling the best's subset answers (trials.csv keeps none).
    tuning::RunDirectory files(dir_ / "mf", e, {"core", "d", "dn", "m", "v", "now"});
    files.write_results(run.summary());
    // The model gave the stopped proposal's estimate a noise of its own; the run records it.
    EXPECT_GT(run.hyperparameters().low_fidelity_noise, 0.0);
    files.append_hyperparameters(3, run.hyperparameters());
    {
        std::ifstream in(dir_ / "mf" / "gp_hyperparameters.csv");
        std::string header;
        std::getline(in, header);
        EXPECT_NE(header.find(",low_fidelity_noise"), std::string::npos) << header;
    }
    const auto trials = experiment::read_trials_csv(files.trials_file(), e.space);
    ASSERT_EQ(trials.size(), 3u);
    EXPECT_EQ(trials[1].fidelity, 4);
    EXPECT_DOUBLE_EQ(trials[2].elapsed_s, 9.0);
    auto resumed = make_mf(e);
    resumed.resume(trials);
    EXPECT_EQ(resumed.summary().best, 2);
    const auto recall = resumed.ask(1, 100.0);
    ASSERT_EQ(recall.size(), 1u) << "the recall alone: nothing is judged on the subset before it";
    EXPECT_EQ(recall[0].view, "complete/4");
    EXPECT_EQ(resumed.set_key(recall[0].params), resumed.set_key(whole.params));
    EXPECT_TRUE(resumed.ask(1, 100.5).empty()) << "still waiting for the recall";
    EXPECT_EQ(resumed.due_resends(100.0 + 16).size(), 1u) << "an unanswered recall is sent again";
    ASSERT_EQ(resumed.tell(answer_n(recall[0], kSubset, 75, 4), 100.9), ReplyOutcome::kRecalled);
    EXPECT_EQ(resumed.summary().evaluations.size(), 3u) << "a recall is no evaluation";
    const auto next = resumed.ask(1, 101.0).at(0);
    EXPECT_EQ(next.view, "complete/4");
    ASSERT_EQ(resumed.tell(answer_n(next, kSubset, 0, 4), 101.0, &rec), ReplyOutcome::kAccepted);
    EXPECT_EQ(rec.fidelity, 4);
    EXPECT_DOUBLE_EQ(rec.elapsed_s, 10.0);
}

// Exactly-once under restarts: a resumed multi-fidelity run decides on the subset as the
// uninterrupted run does, because it compares on the same pairs (the recalled answers).
TEST_F(FidelityTest, AResumedRunJudgesTheSubsetAsTheUninterruptedOne) {
    auto e = load("fidelity: {subset: 4}\nbudget: {evaluations: 6}\n");
    // Per life: the subset answer that matches `matched` of the best's 75 subset pairs.
    auto decide = [&](tuning::TuningRun& run, std::size_t matched, tuning::EvaluationRecord* rec) {
        const auto r = run.ask(1, 50.0).at(0);
        EXPECT_EQ(r.view, "complete/4");
        return std::make_pair(run.set_key(r.params), run.tell(answer_n(r, kSubset, matched, 4), 51.0, rec));
    };
    for (const std::size_t matched : {60u, 70u, 75u}) {
        SCOPED_TRACE(matched);
        auto first = make_mf(e);
        const auto start = first.ask(1, 0.0).at(0);
        ASSERT_EQ(first.tell(answer_n(start, kView, 300), 1.0), ReplyOutcome::kAccepted);
        tuning::RunDirectory files(dir_ / ("r" + std::to_string(matched)), e, {"core", "d", "dn", "m", "v", "now"});
        files.write_results(first.summary());
        const auto trials = experiment::read_trials_csv(files.trials_file(), e.space);

        tuning::EvaluationRecord a, b, c;
        const auto [key_a, outcome_a] = decide(first, matched, &a);

        auto second = make_mf(e);
        second.resume(trials);
        const auto recall = second.ask(1, 10.0);
        ASSERT_EQ(recall.size(), 1u);
        ASSERT_EQ(second.tell(answer_n(recall[0], kSubset, 75, 4), 11.0), ReplyOutcome::kRecalled);
        const auto [key_b, outcome_b] = decide(second, matched, &b);
        EXPECT_EQ(key_b, key_a) << "the resumed optimizer proposes the same set";
        EXPECT_EQ(outcome_b, outcome_a);
        if (outcome_a == ReplyOutcome::kAccepted) {
            EXPECT_DOUBLE_EQ(b.p, a.p);
        }

        // A recall that fails leaves the unpaired bound, which lets more through.
        auto third = make_mf(e);
        third.resume(trials);
        auto failed = answer_n(third.ask(1, 10.0).at(0), 0, 0);
        failed.ok = false;
        failed.error = "gone";
        ASSERT_EQ(third.tell(failed, 11.0), ReplyOutcome::kRecalled);
        const auto [key_c, outcome_c] = decide(third, matched, &c);
        EXPECT_EQ(key_c, key_a);
        if (matched == 70u) {  // measured: the two rules differ for 68..72 of 75
            EXPECT_EQ(outcome_a, ReplyOutcome::kAccepted) << "5 of the best's pairs lost: stops on the subset";
            EXPECT_EQ(outcome_c, ReplyOutcome::kContinued) << "the unpaired bound cannot tell";
        }
        if (matched == 75u) {
            EXPECT_EQ(outcome_a, ReplyOutcome::kContinued);
        }
    }
}

// A stopped proposal's estimate is the best's whole-view p plus the difference on the subset:
// on a subset easier than the view, its own p there would rate it above the best it lost to.
TEST_F(FidelityTest, AStoppedProposalIsToldBelowTheBestEvenOnAnEasySubset) {
    auto e = load("fidelity: {subset: 4}\nbudget: {evaluations: 5}\n");
    auto run = make_mf(e);
    const auto start = run.ask(1, 0.0).at(0);
    // The best matched exactly the subset's pairs (every 4th) and nothing else.
    auto best_reply = answer_n(start, kView, 0);
    for (std::size_t i = 0; i < kView; ++i) best_reply.pairs[i].matched = i % 4 == 0;
    tuning::EvaluationRecord best;
    ASSERT_EQ(run.tell(best_reply, 1.0, &best), ReplyOutcome::kAccepted);

    const auto r = run.ask(1, 2.0).at(0);
    ASSERT_EQ(r.view, "complete/4");
    const auto reply = answer_n(r, kSubset, 40, 4);
    const auto mine = outcomes(reply.pairs), theirs = outcomes(best_reply.pairs);
    const measure::MeasureSettings full{e.e_star, run.summary().m_star, e.w_v};
    const std::vector<double> ratings(40, kRating);
    // Preconditions of the case: its own extrapolated p is above the best's, yet it lost on the pairs.
    ASSERT_GT(measure::extrapolate(ratings, kSubset, kView, full, 0).p, best.p);
    const double d = measure::paired_difference(mine, theirs, kView, full, 0).difference;
    ASSERT_LT(d, 0);

    tuning::EvaluationRecord rec;
    ASSERT_EQ(run.tell(reply, 3.0, &rec), ReplyOutcome::kAccepted);
    EXPECT_EQ(rec.fidelity, 4);
    EXPECT_LT(rec.p, best.p);
    EXPECT_NEAR(rec.p, best.p + d, 1e-12);
    EXPECT_EQ(rec.m, 40u) << "m, v and eps stay the subset's own";
}

TEST_F(FidelityTest, ASubsetEstimateIsNeverTheBestWhateverItsP) {
    auto e = load();
    std::vector<experiment::EvaluationRecord> records(3);
    records[0].p = 0.5;
    records[1].p = 0.99;
    records[1].fidelity = 8;
    records[2].p = 0.6;
    records[2].failed = true;
    EXPECT_EQ(experiment::best_index(e, records), 0);
    records[0].fidelity = 8;
    EXPECT_EQ(experiment::best_index(e, records), -1);
}

TEST_F(FidelityTest, WithoutAnIncumbentOrWithASubsetAsLargeAsTheViewEverythingIsWhole) {
    auto e = load("fidelity: {subset: 4}\nbudget: {evaluations: 5}\n");
    e.start_points.clear();
    auto run = make_mf(e);
    const auto first = run.ask(1, 0.0).at(0);
    EXPECT_EQ(first.view, "complete") << "nothing to beat yet";
    ASSERT_EQ(run.tell(answer_n(first, kView, 0), 1.0), ReplyOutcome::kAccepted);
    EXPECT_EQ(run.summary().best, 0);

    tuning::TuningOptions o{"", "same", 15, tuning::Fidelity{"complete/4", kView, kView, &FidelityTest::outcomes}};
    tuning::TuningRun whole(load("fidelity: {subset: 4}\n"), o, &FidelityTest::real_score, 100);
    const auto s = whole.ask(1, 0.0).at(0);
    ASSERT_EQ(whole.tell(answer_n(s, kView, 10), 1.0), ReplyOutcome::kAccepted);
    EXPECT_EQ(whole.ask(1, 1.0).at(0).view, "complete");
}

TEST_F(FidelityTest, ABadFidelityNamesTheKey) {
    for (const char* bad : {"{subset: 1}", "{subset: x}", "{z: 2}", "{subset: 4, z: -1}", "{subset: 4, k: 2}", "8"}) {
        try {
            load(std::string("fidelity: ") + bad + "\n");
            ADD_FAILURE() << "accepted fidelity " << bad;
        } catch (const params::ConfigError& err) {
            EXPECT_NE(std::string(err.what()).find("fidelity"), std::string::npos) << err.what();
        }
    }
}

}  // namespace
}  // namespace maptune
