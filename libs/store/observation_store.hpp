#pragma once
// The observation store: every matcher evaluation ever made on a dataset, across
// experiments (SPEC §5). SQLite in WAL mode, one protobuf record per observation.
// One process writes (sample_db); readers may run concurrently.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "params/parameter_set.hpp"

namespace maptune::store {

// Open-time problems (foreign or corrupt file, unwritable path) and I/O failures.
class StoreError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

enum class PairStatus { kOk, kNoMatch, kFailed, kTimeout };
const char* to_string(PairStatus status);

struct PairRecord {
    std::string pair_id;
    bool matched = false;
    Eigen::Matrix4d T_a_b_est = Eigen::Matrix4d::Identity();  // estimated pose of B in A
    // [s] what the pair costs the matcher from the raw submaps, whatever was cached (reference
    // matcher: both submaps' features + the pair stage).
    double duration_s = 0;
    PairStatus status = PairStatus::kOk;
    std::string reason;  // why FAILED/TIMEOUT; empty otherwise
};

// Empty when a record from a worker can be stored; otherwise what is wrong with it: a
// matched pair needs a finite rigid transform (rotation orthonormal with determinant 1 to
// 1e-3 — float matchers are no more exact —, bottom row 0 0 0 1), and the duration must be
// finite and not negative.
std::string check_pair_record(const PairRecord& record);

// Whether any pair ran out of time: such an answer depends on the machine's load, not only on
// the parameters, so it is returned but not stored (sample_db, Evaluator::evaluate_cached).
bool has_timeouts(const std::vector<PairRecord>& pairs);

struct ObservationKey {
    std::string dataset_id;       // content hash of the dataset
    std::string view;             // "complete" | "subsequent" | custom
    std::string matcher_id;
    std::string matcher_version;
    std::string params_key;       // ParameterSpace::canonical_key of the full rounded set
    bool operator==(const ObservationKey& o) const;
};

struct Observation {
    ObservationKey key;
    params::ParameterSet params;  // full, rounded
    std::vector<PairRecord> pairs;
    double wall_seconds = 0;
    std::int64_t created_unix_ms = 0;  // set by put() when 0
    std::int64_t row_id = 0;           // assigned by the store; order of insertion
};

struct ParamRange {
    std::string name;
    double low = 0;   // inclusive
    double high = 0;  // inclusive
};

struct ObservationFilter {
    std::optional<std::string> dataset_id;
    std::optional<std::string> view;
    std::optional<std::string> matcher_id;
    std::vector<ParamRange> ranges;  // all must hold
    std::size_t limit = 0;           // 0 = no limit
};

class ObservationStore {
public:
    // kReadWrite opens or creates the store at `path`; kReadOnly opens an existing store and
    // never writes to it (no schema, no journal mode: listing must not turn a file into a
    // store). Throws StoreError when the file is not an SQLite database, belongs to another
    // application, is corrupt, or has a newer schema (read-only: also when it is missing or
    // no maptune store yet); such a file is never modified.
    enum class Mode { kReadWrite, kReadOnly };
    explicit ObservationStore(const std::string& path, Mode mode = Mode::kReadWrite);
    ~ObservationStore();
    ObservationStore(const ObservationStore&) = delete;
    ObservationStore& operator=(const ObservationStore&) = delete;
    ObservationStore(ObservationStore&&) noexcept;
    ObservationStore& operator=(ObservationStore&&) noexcept;

    std::optional<Observation> get(const ObservationKey& key) const;
    // The observations of the same set on the same dataset by the same matcher version under
    // other views (a view and its multi-fidelity subsets, "subsequent" and "subsequent/8"): a
    // pair's result does not depend on the view, so sample_db reuses their pairs.
    std::vector<Observation> other_views(const ObservationKey& key) const;
    // Idempotent: true when stored, false when an observation with this key already exists
    // (the first one is kept). Durable when it returns (one transaction, synchronous=FULL).
    bool put(const Observation& observation);
    std::vector<Observation> list(const ObservationFilter& filter = {}) const;
    std::size_t count() const;
    // Deletes the observation with this row id (and its parameter index rows) in one
    // transaction; false when there is none. A later request for its key runs the matcher again.
    bool remove(std::int64_t row_id);
    struct ImportStats {
        std::size_t read = 0, imported = 0, already_present = 0;
    };
    // Copies every observation of `other` whose key this store lacks (keys are content
    // hashes, so stores of other machines or runs merge without conflicts).
    ImportStats import_from(const ObservationStore& other);
    const std::string& path() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace maptune::store
