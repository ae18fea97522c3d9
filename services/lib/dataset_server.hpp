#pragma once
// dataset_server: announces dataset directories (latched, one instance per dataset) and
// serves their files in chunks, so workers on other machines need no shared filesystem.

#include <condition_variable>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "dds/participant.hpp"
#include "maptunePubSubTypes.h"
#include "refusals.hpp"

namespace maptune::services {

struct DatasetServerOptions {
    std::vector<std::filesystem::path> datasets;  // dataset directories (with manifest.yaml)
    std::size_t chunk_bytes = 512 * 1024;
    std::string server_id;                        // empty: generated
};

class DatasetServer {
public:
    // Reads every dataset's manifest and file list; throws on a directory that is not a
    // dataset (start-up error).
    DatasetServer(dds::Participant& participant, DatasetServerOptions options);
    ~DatasetServer();
    DatasetServer(const DatasetServer&) = delete;
    DatasetServer& operator=(const DatasetServer&) = delete;

    const std::vector<std::string>& dataset_ids() const { return ids_; }
    std::size_t requests_served() const;
    std::size_t requests_refused() const;

private:
    struct Served {
        std::filesystem::path dir;
        msg::v1::DatasetAnnouncement announcement;
    };
    void serve_loop();
    void answer(const msg::v1::FileRequest& request);

    DatasetServerOptions options_;
    std::vector<std::string> ids_;
    std::map<std::string, Served> datasets_;
    dds::Writer<msg::v1::DatasetAnnouncement> announcements_;
    dds::Writer<msg::v1::FileChunk> chunks_;
    mutable std::mutex mutex_;
    std::condition_variable cv_;
    std::deque<msg::v1::FileRequest> queue_;
    bool stop_ = false;
    std::size_t served_ = 0, refused_ = 0;
    RefusalLog refusals_{"dataset_server"};
    std::thread thread_;
    // Last, so destroyed first: no callback runs once the rest starts to go away.
    std::vector<dds::Subscription> subscriptions_;
};

// Lists the files of a dataset directory as announced: relative paths, sizes, content hashes.
std::vector<msg::v1::DatasetFile> list_dataset_files(const std::filesystem::path& dir);

}  // namespace maptune::services
