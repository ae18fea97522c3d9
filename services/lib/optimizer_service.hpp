#pragma once
// optimizer: the DDS adapter of the tuning core (libs/tuning): sends its requests as
// ObservationRequests (one in flight per free worker slot, or the experiment's batch), hands
// ObservationReplies back to it, publishes BestSoFar (latched: a late subscriber gets the current
// best at once) and OptimizerStatus, and keeps the run directory's files (tuning::RunDirectory)
// current. A restart with the same run directory resumes from its trials.csv; re-asked sets
// come back from the store.

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dataset_mirror.hpp"
#include "refusals.hpp"
#include "dds/participant.hpp"
#include "experiment/experiment.hpp"
#include "experiment/run_files.hpp"
#include "maptunePubSubTypes.h"
#include "scoring/scoring.hpp"
#include "tuning/tuning_run.hpp"

namespace maptune::services {

struct OptimizerServiceOptions {
    experiment::Experiment experiment;
    std::string dataset_id;               // empty: read from the experiment's dataset dir
    std::filesystem::path run_dir;
    std::string experiment_id;            // empty: the experiment's name
    std::string incarnation;              // empty: a fresh incarnation_id() (tests fix it)
    std::string matcher_id = "lru_matcher";
    // The matcher version the experiment needs (lru_matcher: from its matcher settings); only
    // workers announcing it are used, or workers that take settings when matcher_settings
    // are given. Empty: whatever a worker of matcher_id announces.
    std::string matcher_version;
    // "KEY=VALUE" settings that make matcher_version, carried in every request so that any
    // worker of the same code revision evaluates exactly this matcher.
    std::vector<std::string> matcher_settings;
    double wait_s = 120;                  // for the dataset and the first compatible worker
    double resend_s = 15;                 // re-send an unanswered request (sample_db restarts)
    bool progress_bar = true;             // redraw a bar on a terminal
    std::function<void(const std::string&)> log;  // one line per event; default: stdout
};

using experiment::EvaluationRecord;
using tuning::RunSummary;

class OptimizerService {
public:
    OptimizerService(dds::Participant& participant, DatasetMirror& mirror, OptimizerServiceOptions options);
    // Runs until the evaluation or time budget is used, or a stop signal. Throws only for
    // start-up problems (dataset never announced, no worker, unwritable run dir).
    RunSummary run();

private:
    void log(const std::string& line) const;
    int compatible_slots(std::string* version);
    void publish(const tuning::TuningRun& run, const EvaluationRecord& rec);
    void send(const tuning::Request& r);

    dds::Participant& participant_;
    DatasetMirror& mirror_;
    OptimizerServiceOptions options_;
    dds::Writer<msg::v1::ObservationRequest> requests_;
    dds::Writer<msg::v1::BestSoFar> best_;
    dds::Writer<msg::v1::OptimizerStatus> status_;
    std::mutex mutex_;
    std::vector<msg::v1::ObservationReply> replies_;
    std::map<std::string, msg::v1::WorkerStatus> workers_;
    std::string request_prefix_;  // "<experiment>/<incarnation>/"
    std::string dataset_id_, matcher_version_;
    RefusalLog refusals_{"optimizer", [this](const std::string& line) { log(line); }};
    // Last, so destroyed first: no callback runs once the rest starts to go away.
    std::vector<dds::Subscription> subscriptions_;
};

using experiment::read_trials_csv;
using experiment::trials_csv;

}  // namespace maptune::services
