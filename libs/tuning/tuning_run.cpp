#include "tuning_run.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace maptune::tuning {

namespace {

// Mean seconds per pair of an answer, to 0.1 ms as trials.csv keeps it: a resumed run tells its
// model the same objective.
double mean_pair_seconds(const std::vector<store::PairRecord>& pairs) {
    if (pairs.empty()) return 0.0;
    double seconds = 0;
    for (const auto& pair : pairs) seconds += pair.duration_s;
    return std::round(seconds / static_cast<double>(pairs.size()) * 1e4) / 1e4;
}

// What the model learns from an evaluation, live or read back from trials.csv alike; a
// proposal stopped on the subset (fidelity k ≠ 1) is an estimate.
bo::Observation observation(const experiment::Experiment& e, const EvaluationRecord& r) {
    return {experiment::optimizer_values(e, r.params), experiment::record_objective(e, r), r.failed, r.error,
            r.fidelity != 1};
}

}  // namespace

TuningRun::TuningRun(experiment::Experiment experiment, TuningOptions options, Scorer scorer, double m_star)
    : experiment_(std::move(experiment)),
      options_(std::move(options)),
      scorer_(std::move(scorer)),
      optimizer_(experiment::search_space(experiment_), experiment::optimizer_options(experiment_)) {
    if (options_.experiment_id.empty()) options_.experiment_id = experiment_.name;
    if (options_.incarnation.empty()) throw std::invalid_argument("TuningRun: an incarnation id is required");
    if (!scorer_) throw std::invalid_argument("TuningRun: a scorer is required");
    summary_.m_star = m_star;
    // A subset as large as the view saves nothing: every proposal on the whole view.
    if (options_.fidelity && (options_.fidelity->pairs == 0 || options_.fidelity->pairs >= options_.fidelity->view_pairs ||
                              !options_.fidelity->outcomes)) {
        options_.fidelity.reset();
    }
    for (const auto& sp : experiment_.start_points) {
        optimizer_.add_start_point(experiment::optimizer_values(experiment_, sp));
    }
}

std::string TuningRun::set_key(const params::ParameterSet& set) const {
    const auto& space = experiment_.space;
    try {
        return space.canonical_key(space.round(space.complete(set)));
    } catch (const std::exception&) {
        return {};
    }
}

void TuningRun::resume(const std::vector<EvaluationRecord>& trials) {
    if (trials.empty()) return;
    if (!summary_.evaluations.empty() || !in_flight_.empty() || resumed_ > 0) {
        throw std::logic_error("TuningRun::resume: only before the first evaluation");
    }
    std::vector<bo::Observation> history;
    std::vector<std::string> origins;
    for (const auto& r : trials) {
        history.push_back(observation(experiment_, r));
        origins.push_back(r.origin);
        add(r);
    }
    // A resumed run does not re-add its start points: they are in the history already. The
    // optimizer replays how the history was proposed, so it goes on as if never stopped.
    optimizer_ = bo::Optimizer(experiment::search_space(experiment_), experiment::optimizer_options(experiment_));
    optimizer_.replay(history, origins);
    resumed_ = trials.size();
    sequence_ = trials.size();
    for (const auto& r : trials) elapsed_before_ = std::max(elapsed_before_, r.elapsed_s);
    if (const auto pb = optimizer_.predicted_best()) {
        summary_.predicted_best = experiment::full_set(experiment_, pb->values);
        summary_.predicted_mean = pb->mean;
        summary_.predicted_std = pb->std;
    }
}

void TuningRun::add(EvaluationRecord record) {
    summary_.evaluations.push_back(std::move(record));
    // Best by what the optimizer maximizes: with a run-time budget, a fast set may beat a
    // slightly more accurate one that is too slow.
    summary_.best = experiment::best_index(experiment_, summary_.evaluations);
}

std::string TuningRun::next_id() {
    return options_.experiment_id + "/" + options_.incarnation + "/" + std::to_string(++sequence_);
}

bool TuningRun::subset_passes(const Reply& reply, EvaluationRecord& rec) const {
    const Fidelity& f = *options_.fidelity;
    const auto outcomes = f.outcomes(reply.pairs);
    std::vector<double> ratings;
    for (const double r : outcomes) {
        if (!std::isnan(r)) ratings.push_back(r);
    }
    const measure::MeasureSettings full{experiment_.e_star, summary_.m_star, experiment_.w_v};
    const measure::Extrapolation x = measure::extrapolate(ratings, f.pairs, f.view_pairs, full, experiment_.fidelity_z);
    rec.pair_s = mean_pair_seconds(reply.pairs);
    if (summary_.best < 0) return true;
    const EvaluationRecord& best = summary_.evaluations[static_cast<std::size_t>(summary_.best)];
    bool passes = false;
    const auto it = subset_outcomes_.find(summary_.best);
    const bool paired = it != subset_outcomes_.end();
    if (paired) {
        const auto d = measure::paired_difference(outcomes, it->second, f.view_pairs, full, experiment_.fidelity_z,
                                                  experiment::objective(experiment_, 1.0, rec.pair_s),
                                                  experiment::objective(experiment_, 1.0, best.pair_s));
        passes = d.upper >= 0;
    } else {
        const double upper = experiment::objective(experiment_, x.p_upper, rec.pair_s);
        passes = !experiment::better(experiment_, experiment::record_objective(experiment_, best), upper);
    }
    if (passes) return true;
    // The estimate the model is told: the best's whole-view p plus the difference on the same
    // pairs. The subset's own p carries how easy those pairs are — the same for every set —
    // and told as a level it rated stopped proposals above the best (26 of 77 on one moon run).
    // A set that matched nothing there keeps p = 0: no evidence of a match, and the
    // dead-region model must see it dead.
    rec.p = x.p;
    if (paired && !ratings.empty()) {
        const double dp = measure::paired_difference(outcomes, it->second, f.view_pairs, full, 0).difference;
        rec.p = std::clamp(best.p + dp, 0.0, 1.0);
    }
    rec.v = x.v;
    rec.eps = x.eps;
    rec.m = ratings.size();
    rec.fidelity = experiment_.fidelity_subset;
    return false;
}

std::size_t TuningRun::failed() const {
    std::size_t n = 0;
    for (const auto& e : summary_.evaluations) n += e.failed ? 1 : 0;
    return n;
}

std::optional<std::string> TuningRun::stop_reason(double now_s, bool stop_requested) const {
    if (stop_requested) return std::string("stopped by signal");
    if (static_cast<int>(summary_.evaluations.size()) >= experiment_.max_evaluations) {
        return std::string("evaluation budget used");
    }
    const bool out_of_time = experiment_.max_seconds > 0 && started_at_ && now_s - *started_at_ > experiment_.max_seconds;
    if (out_of_time && in_flight_.empty()) return std::string("time budget used");
    return std::nullopt;
}

std::vector<Request> TuningRun::ask(int slots, double now_s) {
    if (!started_at_) started_at_ = now_s;
    // Proposals that passed their subset are already in flight: their whole-view requests go
    // out whatever the budgets say, as a re-send would.
    std::vector<Request> out = std::move(continuations_);
    continuations_.clear();
    if (experiment_.max_seconds > 0 && now_s - *started_at_ > experiment_.max_seconds) return out;
    // A resumed best has no subset answers (trials.csv keeps none): recall them before any
    // proposal is judged on the subset, once per best.
    const int best = summary_.best;
    if (options_.fidelity && best >= 0 && !subset_outcomes_.count(best) && recalled_.insert(best).second) {
        Recall r;
        r.index = best;
        r.request.id = next_id();
        r.request.params = summary_.evaluations[static_cast<std::size_t>(best)].params;
        r.request.origin = "recall";
        r.request.view = options_.fidelity->view;
        r.last_sent_at = now_s;
        out.push_back(r.request);
        recalls_[r.request.id] = std::move(r);
    }
    if (!recalls_.empty()) return out;
    const int target = experiment_.batch > 0 ? experiment_.batch : std::max(1, slots);
    const int done = static_cast<int>(summary_.evaluations.size());
    while (static_cast<int>(in_flight_.size()) < target &&
           done + static_cast<int>(in_flight_.size()) < experiment_.max_evaluations) {
        const auto proposals = optimizer_.ask(1);
        if (proposals.empty()) break;
        const auto& pr = proposals.front();
        InFlight f;
        f.proposal = pr.id;
        f.request.id = next_id();
        f.request.params = experiment::full_set(experiment_, pr.values);
        f.request.origin = pr.origin;
        // Start points are the reference every report compares with: always the whole view.
        f.request.view = options_.fidelity && summary_.best >= 0 && pr.origin != "start" ? options_.fidelity->view
                                                                                          : experiment_.view;
        f.key = set_key(f.request.params);
        f.sent_at = f.last_sent_at = now_s;
        out.push_back(f.request);
        in_flight_[f.request.id] = std::move(f);
    }
    return out;
}

std::vector<Request> TuningRun::due_resends(double now_s) {
    std::vector<Request> out;
    const auto due = [&](auto& requests) {
        for (auto& [id, f] : requests) {
            if (now_s - f.last_sent_at > options_.resend_s) {
                f.last_sent_at = now_s;
                out.push_back(f.request);
            }
        }
    };
    due(recalls_);
    due(in_flight_);
    return out;
}

ReplyOutcome TuningRun::tell(const Reply& reply, double now_s, EvaluationRecord* accepted) {
    if (const auto rc = recalls_.find(reply.request_id); rc != recalls_.end()) {
        if (reply.ok && set_key(reply.params) != set_key(rc->second.request.params)) return ReplyOutcome::kOtherSet;
        const int index = rc->second.index;
        recalls_.erase(rc);
        if (reply.ok) {
            try {
                subset_outcomes_[index] = options_.fidelity->outcomes(reply.pairs);
            } catch (const std::exception&) {
                // Not comparable on pairs: the unpaired bound stands in, as when the recall failed.
            }
        }
        return ReplyOutcome::kRecalled;
    }
    const auto it = in_flight_.find(reply.request_id);
    if (it == in_flight_.end()) return ReplyOutcome::kNotInFlight;
    // An answer whose set differs is someone else's: never told to the model.
    if (reply.ok && set_key(reply.params) != it->second.key) return ReplyOutcome::kOtherSet;
    InFlight f = it->second;
    in_flight_.erase(it);

    EvaluationRecord rec;
    if (reply.ok && f.request.view != experiment_.view) {
        bool passes = false;
        try {
            passes = subset_passes(reply, rec);
        } catch (const std::exception& ex) {
            rec.failed = true;
            rec.error = std::string("cannot score the reply: ") + ex.what();
        }
        if (passes) {
            f.request.id = next_id();
            f.request.view = experiment_.view;
            f.last_sent_at = now_s;
            continuations_.push_back(f.request);
            in_flight_[f.request.id] = f;
            return ReplyOutcome::kContinued;
        }
    }
    rec.number = static_cast<int>(summary_.evaluations.size()) + 1;
    rec.origin = f.request.origin;
    rec.wall_s = now_s - f.sent_at;
    rec.elapsed_s = elapsed_before_ + now_s - started_at_.value_or(now_s);
    rec.from_store = reply.from_store;
    rec.params = experiment_.space.round(f.request.params);
    std::string error = reply.ok ? "" : (reply.error.empty() ? std::string("evaluation failed") : reply.error);
    if (rec.failed) error = rec.error;
    if (rec.fidelity != 1) {
        rec.params = experiment_.space.round(reply.params);
    } else if (error.empty()) {
        try {
            const measure::Score s = reply.score ? *reply.score : scorer_(reply.pairs);
            rec.params = experiment_.space.round(reply.params);
            rec.p = s.p;
            rec.v = s.v;
            rec.eps = s.eps;
            rec.m = s.m;
            rec.pair_s = mean_pair_seconds(reply.pairs);
        } catch (const std::exception& ex) {
            error = std::string("cannot score the reply: ") + ex.what();
        }
    }
    if (!error.empty()) {
        rec.failed = true;
        rec.error = error;
        rec.p = rec.v = rec.eps = 0;
        rec.m = 0;
    }
    // The model learns the set as evaluated (rounded by the space), not the proposal's raw
    // values: exactly what a restart reads back from trials.csv, so a resumed run proposes
    // what this one would have proposed.
    // The subset's outcomes of a whole-view evaluation: what later proposals are compared with.
    if (options_.fidelity && !rec.failed && rec.fidelity == 1) {
        try {
            subset_outcomes_[static_cast<int>(summary_.evaluations.size())] = options_.fidelity->outcomes(reply.pairs);
        } catch (const std::exception&) {
            // Not comparable on pairs: the unpaired bound stands in.
        }
    }
    optimizer_.cancel(f.proposal);
    optimizer_.add_observation(observation(experiment_, rec));
    add(rec);
    if (const auto pb = optimizer_.predicted_best()) {
        summary_.predicted_best = experiment::full_set(experiment_, pb->values);
        summary_.predicted_mean = pb->mean;
        summary_.predicted_std = pb->std;
    }
    if (accepted) *accepted = summary_.evaluations.back();
    return ReplyOutcome::kAccepted;
}

}  // namespace maptune::tuning
