#pragma once
// The tuning loop of one run, without transport (issue 12): ask/tell bookkeeping between the
// Bayesian optimizer and whoever evaluates parameter sets, designed like libs/scheduler —
// pure, no DDS, no threads, time is an argument. The DDS optimizer (services/lib/
// optimizer_service.cpp) is a thin adapter over it; tests drive it directly.
//
// What it guarantees:
// - request ids "<experiment>/<incarnation>/<n>" are unique across restarts (a fresh
//   incarnation per process) and across optimizers of one name, so a late reply to an earlier
//   life never answers a current request;
// - a reply is taken only for a request in flight and only when its parameter set is the one
//   asked for (same rounded, completed key); otherwise it is ignored and the request stays in
//   flight — a duplicate answer to a re-sent request is ignored the same way;
// - a reply that is an error or cannot be scored is a failed evaluation (told to the model as
//   a failure), never the end of the run;
// - resuming from the trials of an earlier run restores the history, the best and the
//   evaluation numbering, and never re-adds the start points;
// - with multi-fidelity (Fidelity), a proposal other than a start point is first asked on the
//   subset view; it goes on to the whole view (a new request, the same proposal) only when it
//   can still beat the best so far: the upper bound of its paired difference to the best on
//   the same pairs is >= 0 (measure::paired_difference). trials.csv keeps no per-pair answers,
//   so a resumed run first recalls the best's answers on the subset (a request the sample_db
//   answers from its store, where the best's whole view lies) before it asks anything on the
//   subset, and so decides as the uninterrupted run did; only when that recall fails does the
//   unpaired measure::extrapolate bound against the best's objective stand in. Otherwise the
//   subset's estimate is its evaluation (fidelity k), told to the model, never the best.

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "bo/optimizer.hpp"
#include "experiment/experiment.hpp"
#include "experiment/run_files.hpp"
#include "measure/measure.hpp"
#include "store/observation_store.hpp"

namespace maptune::tuning {

using experiment::EvaluationRecord;

// One parameter set to evaluate.
struct Request {
    std::string id;               // "<experiment_id>/<incarnation>/<n>"
    params::ParameterSet params;  // the full set: optimized values and the experiment's fixed ones
    std::string origin;           // "start", "initial", "model", "quadratic"
    std::string view;             // the experiment's view, or the subset view of multi-fidelity
};

// An evaluator's answer to a request.
struct Reply {
    std::string request_id;
    bool ok = true;
    std::string error;                     // why not ok
    params::ParameterSet params;           // the set the answer is for
    std::vector<store::PairRecord> pairs;  // per-pair results of the view
    std::optional<measure::Score> score;   // given: taken as is (a black-box objective's value as p)
    bool from_store = false;
};

// Scores the per-pair results of an answer (throws when they cannot be scored).
using Scorer = std::function<measure::Score(const std::vector<store::PairRecord>&)>;

struct RunSummary {
    std::vector<EvaluationRecord> evaluations;
    int best = -1;  // index into evaluations
    std::optional<params::ParameterSet> predicted_best;
    double predicted_mean = 0, predicted_std = 0;
    double m_star = 0;
    std::string stop_reason;
};

// Multi-fidelity (the experiment's `fidelity:`): the subset view and how to rate answers on it.
struct Fidelity {
    std::string view;             // "<view>/<k>"
    std::size_t pairs = 0;        // pairs of the subset
    std::size_t view_pairs = 0;   // pairs of the whole view
    // One outcome per pair of the subset, in its order, from an answer holding them (the
    // subset's or the whole view's): NaN when not matched, else r_i. Throws when it cannot be
    // scored.
    std::function<std::vector<double>(const std::vector<store::PairRecord>&)> outcomes;
};

struct TuningOptions {
    std::string experiment_id;  // empty: the experiment's name
    std::string incarnation;    // required: unique per process life
    double resend_s = 15;       // re-send a request unanswered this long (the evaluator restarting)
    // Given (and smaller than the view) when the experiment asks for multi-fidelity.
    std::optional<Fidelity> fidelity;
};

enum class ReplyOutcome {
    kAccepted,    // a new evaluation (successful or failed)
    kContinued,   // the subset answer can still beat the best: the whole view is asked next
    kNotInFlight, // no such request in flight: another optimizer's, an earlier life's, a duplicate
    kOtherSet,    // the request is ours but the answer is for another parameter set
    kRecalled,    // the best's subset answers after a resume (no evaluation)
};

class TuningRun {
public:
    TuningRun(experiment::Experiment experiment, TuningOptions options, Scorer scorer, double m_star);

    // Restores an earlier run's evaluations (its trials.csv); call before the first ask.
    void resume(const std::vector<EvaluationRecord>& trials);

    // New requests so that min(slots, batch) are in flight, within the evaluation budget and
    // not after the time budget ran out, and first the whole-view requests of proposals that
    // passed their subset. `now_s` is any monotonic clock in seconds.
    std::vector<Request> ask(int slots, double now_s);
    // Requests unanswered for resend_s since they were last sent; marks them sent at now_s.
    std::vector<Request> due_resends(double now_s);
    // Takes an answer; `accepted` (when given) receives the new evaluation.
    ReplyOutcome tell(const Reply& reply, double now_s, EvaluationRecord* accepted = nullptr);

    // Why the run ends now (empty: go on). The time budget ends it once nothing is in flight.
    std::optional<std::string> stop_reason(double now_s, bool stop_requested) const;
    // Records the reason in the summary.
    void finish(const std::string& reason) { summary_.stop_reason = reason; }

    const RunSummary& summary() const { return summary_; }
    const experiment::Experiment& experiment() const { return experiment_; }
    const std::string& experiment_id() const { return options_.experiment_id; }
    std::size_t in_flight() const { return in_flight_.size(); }
    std::size_t failed() const;
    std::size_t resumed() const { return resumed_; }
    const gp::Hyperparameters& hyperparameters() const { return optimizer_.hyperparameters(); }
    // The key under which two sets are the same (rounded by the space, completed with defaults);
    // empty for a set the space rejects.
    std::string set_key(const params::ParameterSet& set) const;

private:
    struct InFlight {
        std::uint64_t proposal = 0;
        Request request;
        std::string key;
        double sent_at = 0, last_sent_at = 0;
    };
    void add(EvaluationRecord record);
    std::string next_id();
    // Whether the subset answer `reply` lets its proposal go on to the whole view; otherwise
    // fills `rec` with the subset's estimate.
    bool subset_passes(const Reply& reply, EvaluationRecord& rec) const;

    experiment::Experiment experiment_;
    TuningOptions options_;
    Scorer scorer_;
    bo::Optimizer optimizer_;
    RunSummary summary_;
    std::map<std::string, InFlight> in_flight_;
    std::uint64_t sequence_ = 0;
    std::size_t resumed_ = 0;
    std::optional<double> started_at_;
    double elapsed_before_ = 0;             // elapsed_s of a resumed run's last record
    std::vector<Request> continuations_;    // whole-view requests to send
    std::map<int, std::vector<double>> subset_outcomes_;  // evaluation index -> its subset outcomes
    struct Recall {
        int index = 0;  // the evaluation whose subset answers are asked for
        Request request;
        double last_sent_at = 0;
    };
    std::map<std::string, Recall> recalls_;  // by request id
    std::set<int> recalled_;                 // evaluation indices whose recall was asked
};

}  // namespace maptune::tuning
