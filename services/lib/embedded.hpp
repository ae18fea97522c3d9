#pragma once
// `maptune run`: the whole system in one process — dataset_server, sample_db, matcher
// workers and optimizer, each with its own DDS participant on a private random domain (the
// same code path as separate processes).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "optimizer_service.hpp"

namespace maptune::services {

struct EmbeddedOptions {
    std::string experiment_file;
    std::filesystem::path run_dir;   // empty: runs/<experiment>-<UTC time>
    std::string db_path;             // empty: <run_dir>/observations.db
    int workers = 0;                 // 0: the experiment's
    int domain_id = -1;              // -1: random in [1, 200], one no other maptune process holds
    bool analytic = false;           // the analytic test matcher instead of the PCL pipeline
    // Start no workers: wait for workers started apart (plug-ins, other machines) of the
    // experiment's matcher.id on this domain, up to `wait_s` for the first one.
    bool external_workers = false;
    double wait_s = 120;
    bool progress_bar = true;
    bool locality = true;            // false: sample_db's --no-locality (measurements)
    std::vector<std::uint64_t> seeds;  // empty: the experiment's `seeds`, else its one seed
    // Evaluations per seed; 0: the experiment's `budget.evaluations`. A larger one on an
    // existing run directory extends a finished run.
    int budget = 0;
    // DDS-Security PKI (scripts/make-pki.sh); every service in the process uses its role's
    // identity. Empty: off.
    std::string dds_security;
};

// What ran: with several seeds, one run directory per seed (seed-<n>) under `root`, which
// holds the shared observation store.
struct EmbeddedResult {
    experiment::Experiment experiment;  // as loaded (validation reads its `validate:`)
    std::filesystem::path root;
    std::string db_path;
    struct SeedRun {
        std::uint64_t seed = 0;
        std::filesystem::path run_dir;
        RunSummary summary;
    };
    std::vector<SeedRun> runs;
};

// Runs the experiment to its budget (once per seed) and prints the summary (best next to the
// baseline). Returns the process exit code; `result` (optional) gets the run directories.
int run_embedded(const EmbeddedOptions& options, EmbeddedResult* result = nullptr);

}  // namespace maptune::services
