#include "optimizer_service.hpp"

#include <unistd.h>

#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

#include "bo/optimizer.hpp"
#include "dataset/io.hpp"
#include "dds/convert.hpp"
#include "params/export.hpp"
#include "params/yaml_util.hpp"
#include "runtime.hpp"

namespace maptune::services {

namespace fs = std::filesystem;
namespace v1 = msg::v1;

namespace {

std::string fmt(double v, int decimals = 4) { return params::format_fixed(v, decimals); }
// Shortest text that reads back as the same double (YAML's own emitter writes 17 digits).
std::string num(double v) { return params::format_double(v); }

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
            std::lock_guard<std::mutex> lock(mutex_);
            replies_.push_back(r);
        }));
    subscriptions_.push_back(participant.reader<v1::WorkerStatusPubSubType>(
        dds::topics::kWorkerStatus, dds::TopicQos::kLatched, [this](const v1::WorkerStatus& s) {
            std::lock_guard<std::mutex> lock(mutex_);
            workers_[s.worker_id()] = s;
        }));
}

bool OptimizerService::same_set(const v1::ObservationReply& reply, const v1::ObservationRequest& request) const {
    const auto& space = options_.experiment.space;
    auto key = [&](const std::vector<v1::NamedValue>& values) {
        return space.canonical_key(space.round(space.complete(dds::from_msg(values))));
    };
    try {
        return key(reply.params()) == key(request.params());
    } catch (const std::exception&) {
        return false;  // a set the space rejects is not ours
    }
}

void OptimizerService::log(const std::string& line) const {
    if (options_.log) {
        options_.log(line);
    } else {
        std::cout << line << std::endl;
    }
}

void OptimizerService::write_files(const RunSummary& summary) const {
    const auto& e = options_.experiment;
    dataset::write_file(options_.run_dir / "trials.csv", trials_csv(summary.evaluations, e.space));
    if (summary.best >= 0) {
        const auto& b = summary.evaluations[static_cast<std::size_t>(summary.best)];
        const std::string header = "best of experiment " + options_.experiment_id + ": p = " +
                                   fmt(b.p) + ", m = " + std::to_string(b.m) + " (evaluation " +
                                   std::to_string(b.number) + ")";
        dataset::write_file(options_.run_dir / "best_params.yaml", params::to_plain_yaml(b.params, e.space, header));
        dataset::write_file(options_.run_dir / "best_params.ros2.yaml",
                            "# " + header + "\n" + params::to_ros2_yaml(b.params, e.space, "map_matcher"));
    }
    if (summary.predicted_best) {
        const std::string header = "predicted best of experiment " + options_.experiment_id +
                                   " (GP posterior mean " + fmt(summary.predicted_mean) + " +- " +
                                   fmt(summary.predicted_std) + " after " +
                                   std::to_string(summary.evaluations.size()) + " evaluations)";
        dataset::write_file(options_.run_dir / "predicted_best.yaml",
                            params::to_plain_yaml(e.space.round(*summary.predicted_best), e.space, header));
    }
}

void OptimizerService::write_run_record(const RunSummary& summary, bool finished) const {
    const auto& e = options_.experiment;
    YAML::Emitter out;
    out << YAML::BeginMap;
    out << YAML::Key << "experiment" << YAML::Value << e.name;
    out << YAML::Key << "experiment_id" << YAML::Value << options_.experiment_id;
    std::error_code ec;
    const fs::path file = e.file.empty() ? fs::path() : fs::absolute(e.file, ec).lexically_normal();
    out << YAML::Key << "experiment_file" << YAML::Value << file.string();
    out << YAML::Key << "dataset" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "dir" << YAML::Value << fs::absolute(e.dataset_dir, ec).lexically_normal().string();
    out << YAML::Key << "id" << YAML::Value << dataset_id_;
    out << YAML::Key << "name" << YAML::Value << dataset_name_;
    out << YAML::Key << "view" << YAML::Value << e.view;
    out << YAML::Key << "reference" << YAML::Value << e.reference;
    out << YAML::EndMap;
    out << YAML::Key << "measure" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "e_star" << YAML::Value << num(e.e_star);
    out << YAML::Key << "m_star" << YAML::Value << num(summary.m_star);
    out << YAML::Key << "m_star_rule" << YAML::Value << (e.m_star ? "given" : "auto");
    out << YAML::Key << "w_v" << YAML::Value << num(e.w_v);
    out << YAML::EndMap;
    out << YAML::Key << "matcher" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << options_.matcher_id;
    out << YAML::Key << "version" << YAML::Value << matcher_version_;
    out << YAML::EndMap;
    out << YAML::Key << "optimizer" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "acquisition" << YAML::Value << e.acquisition;
    out << YAML::Key << "seed" << YAML::Value << e.seed;
    out << YAML::Key << "optimize" << YAML::Value << YAML::Flow << e.optimize;
    out << YAML::EndMap;
    out << YAML::Key << "budget" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "evaluations" << YAML::Value << e.max_evaluations;
    out << YAML::Key << "seconds" << YAML::Value << num(e.max_seconds);
    out << YAML::EndMap;
    out << YAML::Key << "started_utc" << YAML::Value << started_utc_;
    out << YAML::Key << "state" << YAML::Value << (finished ? "finished" : "running");
    if (finished) {
        out << YAML::Key << "finished_utc" << YAML::Value << utc_now();
        out << YAML::Key << "wall_s" << YAML::Value << fmt(now_s() - started_s_, 1);
        out << YAML::Key << "stop_reason" << YAML::Value << summary.stop_reason;
        out << YAML::Key << "evaluations" << YAML::Value << summary.evaluations.size();
        if (summary.best >= 0) {
            const auto& b = summary.evaluations[static_cast<std::size_t>(summary.best)];
            out << YAML::Key << "best" << YAML::Value << YAML::BeginMap;
            out << YAML::Key << "evaluation" << YAML::Value << b.number;
            out << YAML::Key << "p" << YAML::Value << num(b.p);
            out << YAML::EndMap;
        }
    }
    out << YAML::EndMap;
    dataset::write_file(options_.run_dir / "run.yaml",
                        "# maptune run record (written by the optimizer; read by validate and report)\n" +
                            std::string(out.c_str()) + "\n");
}

void OptimizerService::publish(const RunSummary& summary, int iteration) {
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
    (void)iteration;
}

RunSummary OptimizerService::run() {
    const experiment::Experiment& e = options_.experiment;
    fs::create_directories(options_.run_dir);
    RunSummary summary;
    started_s_ = now_s();
    started_utc_ = utc_now();

    // The dataset: a local directory when there is one, else whatever a server announces.
    std::string dataset_id = options_.dataset_id;
    if (dataset_id.empty()) {
        mirror_.add_local(e.dataset_dir);
        dataset_id = dataset::Dataset::open(e.dataset_dir).manifest().id;
    }
    std::string error;
    const auto ds = mirror_.open(dataset_id, options_.wait_s, &error);
    if (!ds) throw std::runtime_error("optimizer: " + error);
    const auto pairs = ds->pairs(dataset::parse_view(e.view), dataset::parse_reference(e.reference));
    if (e.m_star) {
        summary.m_star = *e.m_star;
    } else {
        // m_star: auto counts pairs that overlap under the experiment's own reference: with
        // odometry, the clouds placed by odometry poses — never ground truth.
        const auto reference = dataset::parse_reference(e.reference);
        if (reference == dataset::Reference::odometry) {
            std::set<std::string> ids;
            for (const auto& p : pairs) ids.insert({p.id_a, p.id_b});
            if (!mirror_.ensure_submaps(*ds, {ids.begin(), ids.end()}, options_.wait_s, &error)) {
                throw std::runtime_error("optimizer: m_star auto needs the submap clouds: " + error);
            }
        }
        summary.m_star = scoring::derive_m_star(ds->reference_overlaps(pairs, reference));
    }
    const measure::MeasureSettings settings{e.e_star, summary.m_star, e.w_v};
    log("experiment " + options_.experiment_id + ": dataset " + ds->manifest().name + " (" + dataset_id +
        "), view " + e.view + "/" + e.reference + ", " + std::to_string(pairs.size()) + " pairs, m* = " +
        fmt(summary.m_star, 1) +
        (e.m_star ? "" : " (auto: pairs with " + e.reference + " overlap >= 0.3)") + ", budget " +
        std::to_string(e.max_evaluations) + " evaluations");

    // A compatible worker tells us the matcher version (part of every observation key).
    std::string version;
    auto compatible = [&](int* slots) {
        std::lock_guard<std::mutex> lock(mutex_);
        int n = 0;
        for (const auto& [id, w] : workers_) {
            if (w.matcher_id() != options_.matcher_id || w.space_hash() != e.space.hash()) continue;
            version = w.matcher_version();
            n += static_cast<int>(w.slots());
        }
        if (slots) *slots = n;
        return n > 0;
    };
    if (!wait_for([&] { return compatible(nullptr); }, options_.wait_s)) {
        throw std::runtime_error("optimizer: no matcher worker for matcher '" + options_.matcher_id +
                                 "' with design space " + e.space.hash() + " appeared within " +
                                 fmt(options_.wait_s, 0) + " s");
    }

    dataset_id_ = dataset_id;
    dataset_name_ = ds->manifest().name;
    matcher_version_ = version;
    write_run_record(summary, false);

    // Resume from an earlier run in the same directory.
    const auto resumed = read_trials_csv(options_.run_dir / "trials.csv", e.space);
    std::vector<bo::Observation> history;
    for (auto r : resumed) {
        history.push_back({experiment::optimizer_values(e, r.params), r.p, r.failed, r.error});
        r.origin = r.origin == "resumed" ? r.origin : "resumed";
        summary.evaluations.push_back(r);
        if (!r.failed && (summary.best < 0 || r.p > summary.evaluations[static_cast<std::size_t>(summary.best)].p)) {
            summary.best = static_cast<int>(summary.evaluations.size()) - 1;
        }
    }
    bo::Optimizer opt(experiment::search_space(e), experiment::optimizer_options(e), history);
    if (resumed.empty()) {
        for (const auto& sp : e.start_points) opt.add_start_point(experiment::optimizer_values(e, sp));
    } else {
        log("resumed " + std::to_string(resumed.size()) + " evaluations from " +
            (options_.run_dir / "trials.csv").string());
        // A late `watch` gets the resumed best at once, even when the budget is already used
        // and no new reply (which is what publishes otherwise) will come.
        if (summary.best >= 0) publish(summary, static_cast<int>(resumed.size()));
    }

    std::map<std::string, InFlight> in_flight;
    std::uint64_t sequence = resumed.size();
    const double start = now_s();
    const bool tty = options_.progress_bar && isatty(STDOUT_FILENO);
    std::ofstream hp_file(options_.run_dir / "gp_hyperparameters.csv", std::ios::app);
    if (fs::file_size(options_.run_dir / "gp_hyperparameters.csv") == 0) {
        hp_file << "evaluation,signal_variance,noise_variance";
        for (const auto& name : e.optimize) hp_file << ",length_scale_" << name;
        hp_file << "\n";
    }

    for (;;) {
        const int done = static_cast<int>(summary.evaluations.size());
        if (stop_requested()) {
            summary.stop_reason = "stopped by signal";
            break;
        }
        if (done >= e.max_evaluations) {
            summary.stop_reason = "evaluation budget used";
            break;
        }
        const bool out_of_time = e.max_seconds > 0 && now_s() - start > e.max_seconds;
        if (out_of_time && in_flight.empty()) {
            summary.stop_reason = "time budget used";
            break;
        }
        int slots = 0;
        compatible(&slots);
        const int target = e.batch > 0 ? e.batch : std::max(1, slots);
        while (!out_of_time && static_cast<int>(in_flight.size()) < target &&
               done + static_cast<int>(in_flight.size()) < e.max_evaluations) {
            const auto proposals = opt.ask(1);
            if (proposals.empty()) break;
            const auto& pr = proposals.front();
            InFlight f;
            f.proposal = pr.id;
            f.origin = pr.origin;
            f.request.request_id(request_prefix_ + std::to_string(++sequence));
            f.request.requester(options_.experiment_id);
            f.request.dataset_id(dataset_id);
            f.request.view(e.view);
            f.request.matcher_id(options_.matcher_id);
            f.request.matcher_version(version);
            f.request.space_hash(e.space.hash());
            f.request.params(dds::to_msg(experiment::full_set(e, pr.values)));
            f.sent_at = f.last_sent_at = now_s();
            requests_.write(f.request);
            in_flight[f.request.request_id()] = f;
        }

        std::vector<v1::ObservationReply> replies;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            replies.swap(replies_);
        }
        for (const auto& r : replies) {
            const auto it = in_flight.find(r.request_id());
            if (it == in_flight.end()) continue;  // a duplicate answer to a re-sent request
            // The answer must be for the set we asked about: a reply whose set differs is
            // someone else's (never told to the model); the request stays in flight.
            if (r.ok() && !same_set(r, it->second.request)) {
                log("ignored a reply to " + r.request_id() + " for another parameter set (" + r.params_key() + ")");
                continue;
            }
            const InFlight f = it->second;
            in_flight.erase(it);
            EvaluationRecord rec;
            rec.number = static_cast<int>(summary.evaluations.size()) + 1;
            rec.origin = f.origin;
            rec.wall_s = now_s() - f.sent_at;
            rec.from_store = r.from_store();
            // A reply that cannot be scored (a broken transform from an old sample_db, ...) is a
            // failed evaluation, not the end of the run.
            std::string reply_error = r.ok() ? "" : r.error();
            if (reply_error.empty()) {
                try {
                    rec.params = dds::from_msg(r.params());
                    const auto report = scoring::score_observation(*ds, pairs, dds::from_msg(r.pairs()), settings);
                    rec.p = report.score.p;
                    rec.v = report.score.v;
                    rec.eps = report.score.eps;
                    rec.m = report.score.m;
                } catch (const std::exception& ex) {
                    reply_error = std::string("cannot score the reply: ") + ex.what();
                }
            }
            if (!reply_error.empty()) {
                rec = EvaluationRecord{rec.number, e.space.round(dds::from_msg(f.request.params())), true, reply_error,
                                       rec.from_store, 0, 0, 0, 0, rec.wall_s, rec.origin};
                opt.tell_failed(f.proposal, reply_error);
                log("evaluation " + std::to_string(rec.number) + ": failed: " + reply_error);
            } else {
                opt.tell(f.proposal, rec.p);
            }
            summary.evaluations.push_back(rec);
            if (!rec.failed &&
                (summary.best < 0 || rec.p > summary.evaluations[static_cast<std::size_t>(summary.best)].p)) {
                summary.best = static_cast<int>(summary.evaluations.size()) - 1;
            }
            if (const auto pb = opt.predicted_best()) {
                summary.predicted_best = experiment::full_set(e, pb->values);
                summary.predicted_mean = pb->mean;
                summary.predicted_std = pb->std;
            }
            const auto& hp = opt.hyperparameters();
            if (hp.length_scales.size() == static_cast<Eigen::Index>(e.optimize.size())) {
                hp_file << rec.number << "," << params::format_double(hp.signal_variance) << ","
                        << params::format_double(hp.noise_variance);
                for (Eigen::Index i = 0; i < hp.length_scales.size(); ++i) {
                    hp_file << "," << params::format_double(hp.length_scales(i));
                }
                hp_file << "\n" << std::flush;
            }
            if (!rec.failed) {
                std::string ps;
                for (const auto& name : e.optimize) {
                    const auto* spec = e.space.find(name);
                    ps += " " + name + "=" +
                          (spec->type == params::ParamType::kInt ? fmt(rec.params.get(name), 0)
                                                                 : fmt(rec.params.get(name), 2));
                }
                const auto& best = summary.evaluations[static_cast<std::size_t>(summary.best)];
                if (tty) std::cout << "\r\033[K";
                log("evaluation " + std::to_string(rec.number) + ": p=" + fmt(rec.p) + " m=" +
                    std::to_string(rec.m) + (rec.from_store ? " (stored)" : "") + ps + " | best so far p=" +
                    fmt(best.p) + " (evaluation " + std::to_string(best.number) + ")");
            }
            write_files(summary);
            publish(summary, rec.number);
            v1::OptimizerStatus st;
            st.experiment_id(options_.experiment_id);
            st.state("running");
            st.iteration(static_cast<uint32_t>(rec.number));
            st.evaluations(static_cast<uint32_t>(summary.evaluations.size()));
            st.pending(static_cast<uint32_t>(in_flight.size()));
            uint32_t failed = 0;
            for (const auto& x : summary.evaluations) failed += x.failed ? 1 : 0;
            st.failed(failed);
            std::vector<v1::NamedValue> hpv;
            auto add = [&](const std::string& n, double v) {
                v1::NamedValue nv;
                nv.name(n);
                nv.value(v);
                hpv.push_back(nv);
            };
            add("signal_variance", hp.signal_variance);
            add("noise_variance", hp.noise_variance);
            for (Eigen::Index i = 0; i < hp.length_scales.size() && i < static_cast<Eigen::Index>(e.optimize.size()); ++i) {
                add("length_scale_" + e.optimize[static_cast<std::size_t>(i)], hp.length_scales(i));
            }
            st.gp_hyperparameters(hpv);
            status_.write(st);
        }
        if (tty && !in_flight.empty()) {
            const int n = static_cast<int>(summary.evaluations.size());
            const int width = 30;
            const int filled = e.max_evaluations > 0 ? width * n / e.max_evaluations : 0;
            std::cout << "\r[" << std::string(static_cast<std::size_t>(filled), '#')
                      << std::string(static_cast<std::size_t>(width - filled), '.') << "] " << n << "/"
                      << e.max_evaluations << " evaluations, " << in_flight.size() << " running, "
                      << fmt(now_s() - start, 0) << " s" << std::flush;
        }
        // A request nobody answered (sample_db restarting) is sent again; sample_db answers
        // a repeated key from its store or joins the running job.
        for (auto& [id, f] : in_flight) {
            if (now_s() - f.last_sent_at > options_.resend_s) {
                requests_.write(f.request);
                f.last_sent_at = now_s();
            }
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (tty) std::cout << "\r\033[K" << std::flush;
    v1::OptimizerStatus st;
    st.experiment_id(options_.experiment_id);
    st.state(summary.stop_reason == "stopped by signal" ? "stopped" : "finished");
    st.evaluations(static_cast<uint32_t>(summary.evaluations.size()));
    st.message(summary.stop_reason);
    status_.write(st);
    write_run_record(summary, true);
    return summary;
}

}  // namespace maptune::services
