#include "dataset_server.hpp"

#include <algorithm>

#include "dataset/dataset.hpp"
#include "dataset/io.hpp"
#include "dds/convert.hpp"
#include "dds/validate.hpp"
#include "runtime.hpp"

namespace maptune::services {

namespace fs = std::filesystem;
namespace v1 = msg::v1;

std::vector<v1::DatasetFile> list_dataset_files(const fs::path& dir) {
    std::vector<v1::DatasetFile> files;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (!e.is_regular_file()) continue;
        v1::DatasetFile f;
        f.path(fs::relative(e.path(), dir).generic_string());
        const std::string bytes = dataset::read_file(e.path());
        f.size(bytes.size());
        f.hash(dataset::hex64(dataset::fnv1a(bytes)));
        files.push_back(f);
    }
    std::sort(files.begin(), files.end(),
              [](const v1::DatasetFile& a, const v1::DatasetFile& b) { return a.path() < b.path(); });
    return files;
}

DatasetServer::DatasetServer(dds::Participant& participant, DatasetServerOptions options)
    : options_(std::move(options)) {
    if (options_.server_id.empty()) options_.server_id = make_id("dataset_server");
    if (options_.chunk_bytes == 0) options_.chunk_bytes = 512 * 1024;
    for (const auto& dir : options_.datasets) {
        const auto ds = dataset::Dataset::open(dir);  // throws DatasetError naming the file
        Served s;
        s.dir = dir;
        s.announcement.dataset_id(ds.manifest().id);
        s.announcement.name(ds.manifest().name);
        s.announcement.server_id(options_.server_id);
        s.announcement.files(list_dataset_files(dir));
        // Results are stored under the dataset id: never serve other content under it. The
        // files were just hashed for the announcement; verify with those hashes.
        std::map<std::string, std::uint64_t> hashes;
        for (const auto& f : s.announcement.files()) hashes[f.path()] = std::stoull(f.hash(), nullptr, 16);
        if (std::string recomputed; !ds.verify(&recomputed, &hashes)) {
            throw dataset::DatasetError(fs::path(dir) / "manifest.yaml",
                                        "the files changed since the manifest was written (content id " + recomputed +
                                            ", manifest id " + ds.manifest().id +
                                            "): restore them, or generate/import the dataset again");
        }
        ids_.push_back(ds.manifest().id);
        datasets_[ds.manifest().id] = std::move(s);
    }
    announcements_ = participant.writer<v1::DatasetAnnouncementPubSubType>(
        dds::topics::kDatasetAnnouncement, dds::TopicQos::kLatched);
    chunks_ = participant.writer<v1::FileChunkPubSubType>(dds::topics::kFileChunk,
                                                         dds::TopicQos::kReliable);
    subscriptions_.push_back(participant.reader<v1::FileRequestPubSubType>(
        dds::topics::kFileRequest, dds::TopicQos::kReliable, [this](const v1::FileRequest& r) {
            std::lock_guard<std::mutex> lock(mutex_);
            queue_.push_back(r);
            cv_.notify_one();
        }));
    for (const auto& [id, s] : datasets_) announcements_.write(s.announcement);
    thread_ = std::thread([this] { serve_loop(); });
}

DatasetServer::~DatasetServer() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
        cv_.notify_all();
    }
    thread_.join();
}

std::size_t DatasetServer::requests_served() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return served_;
}

std::size_t DatasetServer::requests_refused() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return refused_;
}

void DatasetServer::serve_loop() {
    for (;;) {
        v1::FileRequest request;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
            if (stop_) return;
            request = queue_.front();
            queue_.pop_front();
        }
        answer(request);
    }
}

void DatasetServer::answer(const v1::FileRequest& request) {
    auto refuse = [&](const std::string& why) {
        v1::FileChunk c;
        c.request_id(request.request_id());
        c.index(0);
        c.count(1);
        c.path(request.path());
        c.error(why);
        chunks_.write(c);
        std::lock_guard<std::mutex> lock(mutex_);
        ++refused_;
    };
    if (auto bad = dds::check(request); !bad.empty()) {
        refusals_.refused("file_request", "", bad);
        if (request.request_id().size() > dds::MessageLimits::kId) return;  // no id to answer to
        return refuse("invalid request: " + bad);
    }
    const auto it = datasets_.find(request.dataset_id());
    // Not ours: stay silent. Another dataset_server on the domain may serve it (one server per
    // dataset is a deployment), and a refusal would end the client's transfer before its chunks.
    if (it == datasets_.end()) return;
    const auto& files = it->second.announcement.files();
    // Only announced files are served: no path leaves the dataset directory.
    const bool listed = std::any_of(files.begin(), files.end(),
                                    [&](const v1::DatasetFile& f) { return f.path() == request.path(); });
    if (!listed) return refuse("'" + request.path() + "' is not a file of dataset " + request.dataset_id());
    std::string bytes;
    try {
        bytes = dataset::read_file(it->second.dir / request.path());
    } catch (const std::exception& e) {
        return refuse(e.what());
    }
    const std::size_t n = std::max<std::size_t>(1, (bytes.size() + options_.chunk_bytes - 1) / options_.chunk_bytes);
    for (std::size_t i = 0; i < n; ++i) {
        v1::FileChunk c;
        c.request_id(request.request_id());
        c.index(static_cast<uint32_t>(i));
        c.count(static_cast<uint32_t>(n));
        c.path(request.path());
        const std::size_t begin = i * options_.chunk_bytes;
        const std::size_t end = std::min(bytes.size(), begin + options_.chunk_bytes);
        c.data().assign(bytes.begin() + static_cast<std::ptrdiff_t>(begin),
                        bytes.begin() + static_cast<std::ptrdiff_t>(end));
        chunks_.write(c);
    }
    std::lock_guard<std::mutex> lock(mutex_);
    ++served_;
}

}  // namespace maptune::services
