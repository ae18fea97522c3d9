#pragma once
// Client of dataset_server: learns the announced datasets and mirrors the files it needs into
// a local cache directory (<cache>/<dataset id>/...), verified by content hash. A dataset
// directory that is available locally can be registered instead (embedded runs, shared disks).

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "dataset/dataset.hpp"
#include "dds/participant.hpp"
#include "maptunePubSubTypes.h"
#include "refusals.hpp"

namespace maptune::services {

class DatasetMirror {
public:
    DatasetMirror(dds::Participant& participant, std::filesystem::path cache_root,
                  std::string client_id);

    // Uses `dir` for the dataset it holds instead of fetching (no copies).
    void add_local(const std::filesystem::path& dir);

    // True once the dataset was announced (or registered locally) within `timeout_s`.
    bool wait_for(const std::string& dataset_id, double timeout_s);
    // Ends every wait and transfer in progress, now and later (their callers get "timed out"):
    // for an owner that shuts down while a transfer hangs.
    void interrupt();
    std::vector<std::string> known() const;

    // Makes the dataset's metadata (manifest, trajectories, pair lists: everything but
    // clouds and OctoMaps) available and opens it. Empty optional and `error` set on failure.
    std::optional<dataset::Dataset> open(const std::string& dataset_id, double timeout_s,
                                         std::string* error);
    // Makes the files of these submaps available (cloud, obstacles, OctoMap).
    bool ensure_submaps(const dataset::Dataset& ds, const std::vector<std::string>& submap_ids,
                        double timeout_s, std::string* error);

    std::size_t files_fetched() const;

private:
    // A transfer that receives no chunk for this long is requested again.
    static constexpr std::chrono::seconds kRetry{3};
    struct Transfer {
        std::string path;
        std::vector<std::string> chunks;
        std::size_t received = 0;
        std::size_t count = 0;
        std::string error;
        bool done = false;
    };
    // Fetches the listed files that are missing or stale; true when all are present.
    bool fetch(const std::string& dataset_id, const std::vector<std::string>& paths,
               double timeout_s, std::string* error);
    std::filesystem::path dir_of(const std::string& dataset_id) const;

    std::filesystem::path cache_root_;
    std::string client_id_;
    dds::Writer<msg::v1::FileRequest> requests_;
    mutable std::mutex mutex_;
    bool interrupted_ = false;
    std::condition_variable cv_;
    std::map<std::string, msg::v1::DatasetAnnouncement> announced_;
    std::map<std::string, std::filesystem::path> local_;
    std::map<std::string, Transfer> transfers_;  // by request id
    std::uint64_t next_request_ = 1;
    std::size_t fetched_ = 0;
    RefusalLog refusals_{"dataset_mirror"};
    // Last, so destroyed first: no callback runs once the rest starts to go away.
    std::vector<dds::Subscription> subscriptions_;
};

}  // namespace maptune::services
