#pragma once
// optimizer: runs an experiment by Bayesian optimization in ask/tell form over DDS. Keeps one
// request in flight per free worker slot (or the experiment's batch), scores each reply
// against the experiment's reference, publishes BestSoFar (latched: a late subscriber gets
// the current best at once) and OptimizerStatus, and writes the run directory: run.yaml (what
// ran, on what, when: `maptune validate` and `report` read it), trials.csv, best_params.yaml,
// best_params.ros2.yaml, predicted_best.yaml (the model's), gp_hyperparameters.csv. A restart with the same
// run directory resumes from its trials.csv; re-asked sets come back from the store.

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dataset_mirror.hpp"
#include "dds/participant.hpp"
#include "experiment/experiment.hpp"
#include "experiment/run_files.hpp"
#include "maptunePubSubTypes.h"
#include "scoring/scoring.hpp"

namespace maptune::services {

struct OptimizerServiceOptions {
    experiment::Experiment experiment;
    std::string dataset_id;               // empty: read from the experiment's dataset dir
    std::filesystem::path run_dir;
    std::string experiment_id;            // empty: the experiment's name
    std::string incarnation;              // empty: a fresh incarnation_id() (tests fix it)
    std::string matcher_id = "lru_matcher";
    double wait_s = 120;                  // for the dataset and the first compatible worker
    double resend_s = 15;                 // re-send an unanswered request (sample_db restarts)
    bool progress_bar = true;             // redraw a bar on a terminal
    std::function<void(const std::string&)> log;  // one line per event; default: stdout
};

using experiment::EvaluationRecord;

struct RunSummary {
    std::vector<EvaluationRecord> evaluations;
    int best = -1;                   // index into evaluations
    std::optional<params::ParameterSet> predicted_best;
    double predicted_mean = 0, predicted_std = 0;
    double m_star = 0;
    std::string stop_reason;
};

class OptimizerService {
public:
    OptimizerService(dds::Participant& participant, DatasetMirror& mirror, OptimizerServiceOptions options);
    // Runs until the evaluation or time budget is used, or a stop signal. Throws only for
    // start-up problems (dataset never announced, no worker, unwritable run dir).
    RunSummary run();

private:
    struct InFlight {
        std::uint64_t proposal = 0;
        msg::v1::ObservationRequest request;
        double sent_at = 0;       // first send: the evaluation's wall time starts here
        double last_sent_at = 0;  // for re-sending
        std::string origin;
    };
    void log(const std::string& line) const;
    // Whether a reply is for the parameter set of the request (rounded, completed keys).
    bool same_set(const msg::v1::ObservationReply& reply, const msg::v1::ObservationRequest& request) const;
    void write_files(const RunSummary& summary) const;
    // run.yaml; `finished` adds the end time, wall time and stop reason.
    void write_run_record(const RunSummary& summary, bool finished) const;
    void publish(const RunSummary& summary, int iteration);

    dds::Participant& participant_;
    DatasetMirror& mirror_;
    OptimizerServiceOptions options_;
    dds::Writer<msg::v1::ObservationRequest> requests_;
    dds::Writer<msg::v1::BestSoFar> best_;
    dds::Writer<msg::v1::OptimizerStatus> status_;
    std::mutex mutex_;
    std::vector<msg::v1::ObservationReply> replies_;
    std::map<std::string, msg::v1::WorkerStatus> workers_;
    std::string last_hyperparameters_;
    std::string request_prefix_;  // "<experiment>/<incarnation>/"
    // For run.yaml.
    std::string dataset_id_, dataset_name_, matcher_version_, started_utc_;
    double started_s_ = 0;
    // Last, so destroyed first: no callback runs once the rest starts to go away.
    std::vector<dds::Subscription> subscriptions_;
};

using experiment::read_trials_csv;
using experiment::trials_csv;

}  // namespace maptune::services
