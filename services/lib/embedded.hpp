#pragma once
// `maptune run`: the whole system in one process — dataset_server, sample_db, matcher
// workers and optimizer, each with its own DDS participant on a private random domain (the
// same code path as separate processes).

#include <filesystem>
#include <string>

#include "optimizer_service.hpp"

namespace maptune::services {

struct EmbeddedOptions {
    std::string experiment_file;
    std::filesystem::path run_dir;   // empty: runs/<experiment>-<UTC time>
    std::string db_path;             // empty: <run_dir>/observations.db
    int workers = 0;                 // 0: the experiment's
    int domain_id = -1;              // -1: random in [1, 200]
    bool analytic = false;           // the analytic test matcher instead of the PCL pipeline
    bool progress_bar = true;
};

// Runs the experiment to its budget and prints the summary (best next to the baseline).
// Returns the process exit code.
int run_embedded(const EmbeddedOptions& options);

}  // namespace maptune::services
