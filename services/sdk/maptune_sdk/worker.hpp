#pragma once
// maptune's worker SDK: what a robot team links to put its own matcher under tuning
// (docs/plugin-matcher.md). Implement `Matcher`, call `run_worker`; heartbeats, task leases,
// dataset transfer from the dataset_server, DDS (with DDS-Security when configured) and
// SIGINT/SIGTERM are the SDK's. No DDS type or header reaches the plug-in: its build needs
// only this header, libs/dataset (to read submaps) and the `maptune::sdk` link target.

#include <array>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dataset/dataset.hpp"

namespace maptune::sdk {

// One evaluation task: a parameter set on some pairs of a dataset view.
struct Task {
    std::string task_id;
    std::string dataset_id;
    std::string view;                        // "complete", "subsequent", "<view>/<k>"
    std::map<std::string, double> params;    // the full set of the matcher's design space
    std::vector<std::string> pair_ids;       // "<submap id A>|<submap id B>"
};

enum class PairStatus { kOk, kNoMatch, kFailed, kTimeout };

// The matcher's answer for one pair: the transform taking B's points into A's frame.
struct PairResult {
    std::string pair_id;
    bool matched = false;
    std::array<double, 16> T_a_b{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // row-major
    double duration_s = 0;
    PairStatus status = PairStatus::kNoMatch;
    std::string reason;                      // why not matched / failed
};

struct Outcome {
    bool ok = false;                         // false: the whole task failed (`error` says why)
    std::string error;
    std::vector<PairResult> pairs;           // ok: one per pair id, in the task's order
};

// The datasets of the tasks: fetched from the dataset_server into the worker's cache (or read
// from a local directory), verified by hash.
class Datasets {
public:
    virtual ~Datasets() = default;
    // Manifest, trajectories and pair lists; nullptr with `error` when not available.
    virtual std::shared_ptr<const dataset::Dataset> open(const std::string& dataset_id, std::string* error) = 0;
    // Makes these submaps' files (cloud, obstacles, OctoMap) available for load_submap.
    virtual bool ensure_submaps(const dataset::Dataset& ds, const std::vector<std::string>& submap_ids,
                                std::string* error) = 0;
};

class Matcher {
public:
    virtual ~Matcher() = default;
    virtual std::string id() const = 0;       // the experiment's matcher.id
    virtual std::string version() const = 0;  // changes whenever results would change
    // Called from `slots` threads at once; must not throw (failures are outcomes).
    virtual Outcome run(const Task& task, Datasets& datasets) = 0;
};

// What most matchers do with a task: open its dataset, then for each pair make both submaps
// available and call `match(dataset, a_id, b_id, result)` (result.pair_id set, status
// kNoMatch), timing it into result.duration_s. An exception from `match` makes that pair
// PAIR_FAILED with its message; a malformed pair id or data that cannot be had fails the task.
using PairMatch = std::function<void(const dataset::Dataset& dataset, const std::string& a_id,
                                     const std::string& b_id, PairResult& result)>;
Outcome run_pairs(const Task& task, Datasets& datasets, const PairMatch& match);

struct WorkerConfig {
    std::string space_file;                  // the matcher's design space YAML (required)
    std::string worker_id;                   // "" = generated from host and pid
    int slots = 1;                           // tasks run at once
    std::filesystem::path cache = "/tmp/maptune-cache";  // fetched dataset files
    std::filesystem::path local_dataset;     // read this dataset directory instead of fetching
    int domain = 0;                          // DDS domain, 0..232
    std::string dds_profiles;                // Fast DDS XML ("" = built-in loopback only)
    std::string dds_profile = "maptune_loopback";
    std::string dds_security;                // DDS-Security PKI directory ("" = off)
    std::string dds_identity = "worker";
};

// Serves tasks until SIGINT/SIGTERM (or `stop` returns true, polled every 100 ms). Returns the
// process exit code: 0 after a clean stop, 1 with a message on stderr when it cannot start.
int run_worker(const WorkerConfig& config, Matcher& matcher, bool (*stop)() = nullptr);

// The usual command line (--space, --id, --slots, --cache, --dataset-dir, --domain,
// --dds-profiles, --dds-profile, --dds-security, --dds-identity and their MAPTUNE_*
// environment variables) into `config`. Returns -1 to go on, else the exit code (help, error).
int parse_worker_args(int argc, char** argv, const std::string& description, WorkerConfig& config);

}  // namespace maptune::sdk
