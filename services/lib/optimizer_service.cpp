#include "optimizer_service.hpp"

#include <unistd.h>

#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

#include "bo/optimizer.hpp"
#include "dataset/io.hpp"
#include "dds/convert.hpp"
#include "dds/validate.hpp"
#include "params/export.hpp"
#include "params/yaml_util.hpp"
#include "runtime.hpp"
#include "scheduler/scheduler.hpp"
#include "tuning/run_directory.hpp"

namespace maptune::services {

namespace fs = std::filesystem;
namespace v1 = msg::v1;

namespace {

std::string fmt(double v, int decimals = 4) { return params::format_fixed(v, decimals); }

tuning::Reply to_reply(const v1::ObservationReply& m) {
    tuning::Reply r;
    r.request_id = m.request_id();
    r.ok = m.ok();
    r.error = m.error();
    r.from_store = m.from_store();
    if (!r.ok) return r;
    try {
        r.params = dds::from_msg(m.params());
    } catch (const std::exception&) {
        return r;  // no set to compare: not an answer to what we asked (the core ignores it)
    }
    try {
        r.pairs = dds::from_msg(m.pairs());
    } catch (const std::exception& ex) {
        r.ok = false;
        r.error = std::string("cannot score the reply: ") + ex.what();
    }
    return r;
}

void progress_bar(const tuning::TuningRun& run, double elapsed_s) {
    const int n = static_cast<int>(run.summary().evaluations.size());
    const int budget = run.experiment().max_evaluations;
    const int width = 30;
    const int filled = budget > 0 ? std::min(width, width * n / budget) : 0;
    std::cout << "\r[" << std::string(static_cast<std::size_t>(filled), '#')
              << std::string(static_cast<std::size_t>(width - filled), '.') << "] " << n << "/" << budget
              << " evaluations, " << run.in_flight() << " running, " << fmt(elapsed_s, 0) << " s" << std::flush;
}

}  // namespace

OptimizerService::OptimizerService(dds::Participant& participant, DatasetMirror& mirror,
                                   OptimizerServiceOptions options)
    : participant_(participant), mirror_(mirror), options_(std::move(options)) {
    if (options_.experiment_id.empty()) options_.experiment_id = options_.experiment.name;
    if (options_.incarnation.empty()) options_.incarnation = incarnation_id();
    // Request ids "<experiment>/<incarnation>/<n>": unique across restarts and across
    // optimizers of one name, so a late reply to an earlier life is never taken for ours.
    request_prefix_ = options_.experiment_id + "/" + options_.incarnation + "/";
    requests_ = participant.writer<v1::ObservationRequestPubSubType>(dds::topics::kObservationRequest,
                                                                    dds::TopicQos::kReliable);
    best_ = participant.writer<v1::BestSoFarPubSubType>(dds::topics::kBestSoFar, dds::TopicQos::kLatched);
    status_ = participant.writer<v1::OptimizerStatusPubSubType>(dds::topics::kOptimizerStatus,
                                                               dds::TopicQos::kLatched);
    subscriptions_.push_back(participant.reader<v1::ObservationReplyPubSubType>(
        dds::topics::kObservationReply, dds::TopicQos::kReliable, [this](const v1::ObservationReply& r) {
            // Replies for other optimizers (and earlier lives of this one) share the topic.
            if (r.request_id().rfind(request_prefix_, 0) != 0) return;
            // A malformed reply is dropped: the request is re-sent and answered again.
            if (auto bad = dds::check(r); !bad.empty()) return refusals_.refused("observation_reply", "", bad);
            std::lock_guard<std::mutex> lock(mutex_);
            replies_.push_back(r);
        }));
    subscriptions_.push_back(participant.reader<v1::WorkerStatusPubSubType>(
        dds::topics::kWorkerStatus, dds::TopicQos::kLatched, [this](const v1::WorkerStatus& s) {
            if (auto bad = dds::check(s); !bad.empty()) return refusals_.refused("worker_status", s.worker_id(), bad);
            std::lock_guard<std::mutex> lock(mutex_);
            workers_[s.worker_id()] = s;
        }));
}

void OptimizerService::log(const std::string& line) const {
    if (options_.log) {
        options_.log(line);
    } else {
        std::cout << line << std::endl;
    }
}

int OptimizerService::compatible_slots(std::string* version) {
    std::lock_guard<std::mutex> lock(mutex_);
    int n = 0;
    for (const auto& [id, w] : workers_) {
        if (w.matcher_id() != options_.matcher_id || w.space_hash() != options_.experiment.space.hash()) continue;
        const bool carried = w.takes_settings() && !options_.matcher_settings.empty() &&
                             scheduler::code_revision(w.matcher_version()) ==
                                 scheduler::code_revision(options_.matcher_version);
        if (!options_.matcher_version.empty() && w.matcher_version() != options_.matcher_version && !carried) continue;
        if (version) *version = options_.matcher_version.empty() ? w.matcher_version() : options_.matcher_version;
        n += static_cast<int>(w.slots());
    }
    return n;
}

void OptimizerService::send(const tuning::Request& r) {
    const auto& e = options_.experiment;
    v1::ObservationRequest m;
    m.request_id(r.id);
    m.requester(options_.experiment_id);
    m.dataset_id(dataset_id_);
    m.view(r.view.empty() ? e.view : r.view);
    m.matcher_id(options_.matcher_id);
    m.matcher_version(matcher_version_);
    m.space_hash(e.space.hash());
    m.params(dds::to_msg(r.params));
    m.matcher_settings(options_.matcher_settings);
    requests_.write(m);
}

void OptimizerService::publish(const tuning::TuningRun& run, const EvaluationRecord& rec) {
    const RunSummary& summary = run.summary();
    v1::BestSoFar b;
    b.experiment_id(options_.experiment_id);
    b.evaluations(static_cast<uint32_t>(summary.evaluations.size()));
    if (summary.best >= 0) {
        const auto& best = summary.evaluations[static_cast<std::size_t>(summary.best)];
        b.best_evaluation(static_cast<uint32_t>(best.number));
        b.best_p(best.p);
        b.best_params(dds::to_msg(best.params));
    }
    if (summary.predicted_best) {
        b.predicted_params(dds::to_msg(*summary.predicted_best));
        b.predicted_mean(summary.predicted_mean);
        b.predicted_std(summary.predicted_std);
    }
    best_.write(b);
    if (rec.number <= 0) return;  // a resumed run's best: no new evaluation to report

    v1::OptimizerStatus st;
    st.experiment_id(options_.experiment_id);
    st.state("running");
    st.iteration(static_cast<uint32_t>(rec.number));
    st.evaluations(static_cast<uint32_t>(summary.evaluations.size()));
    st.pending(static_cast<uint32_t>(run.in_flight()));
    st.failed(static_cast<uint32_t>(run.failed()));
    const auto& hp = run.hyperparameters();
    const auto& names = options_.experiment.optimize;
    std::vector<v1::NamedValue> hpv;
    auto add = [&](const std::string& n, double v) {
        v1::NamedValue nv;
        nv.name(n);
        nv.value(v);
        hpv.push_back(nv);
    };
    add("signal_variance", hp.signal_variance);
    add("noise_variance", hp.noise_variance);
    for (Eigen::Index i = 0; i < hp.length_scales.size() && i < static_cast<Eigen::Index>(names.size()); ++i) {
        add("length_scale_" + names[static_cast<std::size_t>(i)], hp.length_scales(i));
    }
    if (options_.experiment.multi_fidelity()) add("low_fidelity_noise", hp.low_fidelity_noise);
    st.gp_hyperparameters(hpv);
    status_.write(st);

    if (rec.failed) {
        log("evaluation " + std::to_string(rec.number) + ": failed: " + rec.error);
        return;
    }
    std::string ps;
    for (const auto& name : names) {
        const auto* spec = options_.experiment.space.find(name);
        ps += " " + name + "=" + fmt(rec.params.get(name), spec->type == params::ParamType::kInt ? 0 : 2);
    }
    const auto& best = summary.evaluations[static_cast<std::size_t>(summary.best)];
    log("evaluation " + std::to_string(rec.number) + ": p=" + fmt(rec.p) + " m=" + std::to_string(rec.m) +
        (rec.from_store ? " (stored)" : "") +
        (rec.fidelity != 1 ? " (estimate from 1/" + std::to_string(rec.fidelity) + " of the pairs, below the best on the same pairs: stopped there)" : "") +
        ps + " | best so far p=" + fmt(best.p) + " (evaluation " +
        std::to_string(best.number) + ")");
}

RunSummary OptimizerService::run() {
    const experiment::Experiment& e = options_.experiment;
    const double started_s = now_s();
    const std::string started_utc = utc_now();

    // The dataset: a local directory when there is one, else whatever a server announces.
    dataset_id_ = options_.dataset_id;
    if (dataset_id_.empty()) {
        mirror_.add_local(e.dataset_dir);
        dataset_id_ = dataset::Dataset::open(e.dataset_dir).manifest().id;
    }
    std::string error;
    const auto ds = mirror_.open(dataset_id_, options_.wait_s, &error);
    if (!ds) throw std::runtime_error("optimizer: " + error);
    const auto reference = dataset::parse_reference(e.reference);
    const auto pairs = ds->pairs(dataset::parse_view(e.view), reference);
    double m_star = 0;
    std::string m_star_rule;
    if (e.m_star) {
        m_star = *e.m_star;
    } else if (e.m_star_per_pair) {
        m_star = *e.m_star_per_pair * static_cast<double>(pairs.size());
        m_star_rule = " (" + fmt(*e.m_star_per_pair, 4) + " per pair)";
    } else {
        m_star_rule = " (auto: pairs with " + e.reference + " overlap >= 0.3)";
        // m_star: auto counts pairs that overlap under the experiment's own reference: with
        // odometry, the clouds placed by odometry poses — never ground truth.
        if (reference == dataset::Reference::odometry) {
            std::set<std::string> ids;
            for (const auto& p : pairs) ids.insert({p.id_a, p.id_b});
            if (!mirror_.ensure_submaps(*ds, {ids.begin(), ids.end()}, options_.wait_s, &error)) {
                throw std::runtime_error("optimizer: m_star auto needs the submap clouds: " + error);
            }
        }
        m_star = scoring::derive_m_star(ds->reference_overlaps(pairs, reference));
    }
    const measure::MeasureSettings settings{e.e_star, m_star, e.w_v};
    log("experiment " + options_.experiment_id + ": dataset " + ds->manifest().name + " (" + dataset_id_ +
        "), view " + e.view + "/" + e.reference + ", " + std::to_string(pairs.size()) + " pairs, m* = " +
        fmt(m_star, 1) + m_star_rule + ", budget " +
        std::to_string(e.max_evaluations) + " evaluations");

    // A compatible worker tells us the matcher version (part of every observation key).
    if (!wait_for([&] { return compatible_slots(&matcher_version_) > 0; }, options_.wait_s)) {
        std::string others;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            for (const auto& [id, w] : workers_) {
                if (w.matcher_id() == options_.matcher_id && w.space_hash() == e.space.hash()) {
                    others += (others.empty() ? "" : ", ") + id + " (version " + w.matcher_version() + ")";
                }
            }
        }
        throw std::runtime_error(
            "optimizer: no matcher worker for matcher '" + options_.matcher_id + "'" +
            (options_.matcher_version.empty() ? "" : " version " + options_.matcher_version) +
            " with design space " + e.space.hash() + " appeared within " + fmt(options_.wait_s, 0) + " s" +
            (others.empty() ? ""
                            : "; workers of other matcher versions that cannot run these settings: " + others +
                                  " — start workers of this build, or with the experiment's settings "
                                  "(maptune_matcher_worker --experiment FILE)"));
    }

    tuning::TuningOptions tuning_options{options_.experiment_id, options_.incarnation, options_.resend_s, {}};
    std::vector<dataset::SubmapPair> subset;
    if (e.multi_fidelity()) {
        const dataset::ViewSpec spec{dataset::parse_view(e.view), e.fidelity_subset};
        subset = ds->pairs(spec, reference);
        tuning::Fidelity f;
        f.view = spec.str();
        f.pairs = subset.size();
        f.view_pairs = pairs.size();
        f.outcomes = [&](const std::vector<store::PairRecord>& results) {
            std::vector<double> outcomes;
            for (const auto& p : scoring::score_observation(*ds, subset, results, settings).per_pair) {
                outcomes.push_back(p.matched ? p.rating : std::nan(""));
            }
            return outcomes;
        };
        tuning_options.fidelity = f;
        log("multi-fidelity: proposals start on " + f.view + " (" + std::to_string(subset.size()) + " of " +
            std::to_string(pairs.size()) + " pairs) and go on to the whole view when they can still beat the best on those pairs (z = " +
            fmt(e.fidelity_z, 2) + ")");
    }
    tuning::TuningRun run(e, tuning_options,
                          [&](const std::vector<store::PairRecord>& results) {
                              return scoring::score_observation(*ds, pairs, results, settings).score;
                          },
                          m_star);
    const tuning::RunDirectory files(options_.run_dir, e,
                                     {options_.experiment_id, dataset_id_, ds->manifest().name, options_.matcher_id,
                                      matcher_version_, started_utc});
    files.write_record(run.summary());
    run.resume(read_trials_csv(files.trials_file(), e.space));
    if (run.resumed() > 0) {
        if (files.space_change()) log(*files.space_change());
        log("resumed " + std::to_string(run.resumed()) + " evaluations from " + files.trials_file().string());
        // A late `watch` gets the resumed best at once, even when the budget is already used
        // and no new reply (which is what publishes otherwise) will come.
        if (run.summary().best >= 0) publish(run, {});
    }

    const bool tty = options_.progress_bar && isatty(STDOUT_FILENO);
    for (;;) {
        if (const auto reason = run.stop_reason(now_s(), stop_requested())) {
            run.finish(*reason);
            break;
        }
        for (const auto& r : run.ask(compatible_slots(nullptr), now_s())) send(r);
        std::vector<v1::ObservationReply> replies;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            replies.swap(replies_);
        }
        for (const auto& m : replies) {
            tuning::EvaluationRecord rec;
            const auto outcome = run.tell(to_reply(m), now_s(), &rec);
            if (outcome == tuning::ReplyOutcome::kContinued) {
                if (tty) std::cout << "\r\033[K";
                log("proposal of " + m.request_id() + " can still beat the best on the subset: evaluating the whole view");
            }
            if (outcome == tuning::ReplyOutcome::kRecalled) {
                log(std::string("the best's answers on the subset ") + (m.ok() ? "recalled" : "not recallable (" + m.error() + "): judging by the unpaired bound"));
            }
            if (outcome == tuning::ReplyOutcome::kOtherSet) {
                log("ignored a reply to " + m.request_id() + " for another parameter set (" + m.params_key() + ")");
            }
            if (outcome != tuning::ReplyOutcome::kAccepted) continue;
            if (tty) std::cout << "\r\033[K";
            files.write_results(run.summary());
            files.append_hyperparameters(rec.number, run.hyperparameters());
            publish(run, rec);
        }
        if (tty && run.in_flight() > 0) progress_bar(run, now_s() - started_s);
        // A request nobody answered (sample_db restarting) is sent again; sample_db answers
        // a repeated key from its store or joins the running job.
        for (const auto& r : run.due_resends(now_s())) send(r);
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (tty) std::cout << "\r\033[K" << std::flush;
    const RunSummary& summary = run.summary();
    v1::OptimizerStatus st;
    st.experiment_id(options_.experiment_id);
    st.state(summary.stop_reason == "stopped by signal" ? "stopped" : "finished");
    st.evaluations(static_cast<uint32_t>(summary.evaluations.size()));
    st.message(summary.stop_reason);
    status_.write(st);
    files.write_record(summary, tuning::RunEnd{utc_now(), now_s() - started_s});
    return summary;
}

}  // namespace maptune::services
