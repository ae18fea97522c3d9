#include "dataset_mirror.hpp"

#include "dataset/io.hpp"
#include "dds/convert.hpp"
#include "dds/validate.hpp"
#include "runtime.hpp"

namespace maptune::services {

namespace fs = std::filesystem;
namespace v1 = msg::v1;

namespace {

bool is_bulk_file(const std::string& path) {
    const std::string ext = fs::path(path).extension().string();
    return ext == ".pcd" || ext == ".bt" || ext == ".png" || ext == ".ply";
}

}  // namespace

DatasetMirror::DatasetMirror(dds::Participant& participant, fs::path cache_root, std::string client_id)
    // Request ids of this life only: chunks for a transfer of an earlier mirror with the same
    // client id (a restart, or the next seed of `maptune run`) are never taken for ours.
    : cache_root_(std::move(cache_root)), client_id_(std::move(client_id) + "/" + incarnation_id()) {
    requests_ = participant.writer<v1::FileRequestPubSubType>(dds::topics::kFileRequest,
                                                             dds::TopicQos::kReliable);
    subscriptions_.push_back(participant.reader<v1::DatasetAnnouncementPubSubType>(
        dds::topics::kDatasetAnnouncement, dds::TopicQos::kLatched,
        [this](const v1::DatasetAnnouncement& a) {
            if (auto bad = dds::check(a); !bad.empty()) return refusals_.refused("dataset_announcement", a.server_id(), bad);
            std::lock_guard<std::mutex> lock(mutex_);
            announced_[a.dataset_id()] = a;
            cv_.notify_all();
        }));
    subscriptions_.push_back(participant.reader<v1::FileChunkPubSubType>(
        dds::topics::kFileChunk, dds::TopicQos::kReliable, [this](const v1::FileChunk& c) {
            std::lock_guard<std::mutex> lock(mutex_);
            const auto it = transfers_.find(c.request_id());
            if (it == transfers_.end()) return;  // another client's transfer
            // A malformed chunk (e.g. a count that would allocate without bound) is dropped;
            // the transfer asks again after its quiet time.
            if (auto bad = dds::check(c); !bad.empty()) return refusals_.refused("file_chunk", "", bad);
            // Every chunk of a transfer must agree on the count.
            if (it->second.count != 0 && c.count() != it->second.count) {
                return refusals_.refused("file_chunk", "", "count: " + std::to_string(c.count()) + " after " +
                                                               std::to_string(it->second.count));
            }
            Transfer& t = it->second;
            if (!c.error().empty()) {
                t.error = c.error();
                t.done = true;
            } else {
                if (t.count == 0) {
                    t.count = c.count();
                    t.chunks.assign(t.count, std::string());
                }
                if (c.index() < t.count && t.chunks[c.index()].empty()) {
                    t.chunks[c.index()].assign(c.data().begin(), c.data().end());
                    ++t.received;
                    // An empty file arrives as one empty chunk.
                    if (c.data().empty() && t.count == 1) t.received = 1;
                }
                t.done = t.received == t.count;
            }
            cv_.notify_all();
        }));
}

void DatasetMirror::interrupt() {
    std::lock_guard<std::mutex> lock(mutex_);
    interrupted_ = true;
    cv_.notify_all();
}

void DatasetMirror::add_local(const fs::path& dir) {
    const auto ds = dataset::Dataset::open(dir);
    std::lock_guard<std::mutex> lock(mutex_);
    local_[ds.manifest().id] = dir;
    cv_.notify_all();
}

bool DatasetMirror::wait_for(const std::string& dataset_id, double timeout_s) {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] {
        return announced_.count(dataset_id) || local_.count(dataset_id) || stop_requested() || interrupted_;
    }) && !stop_requested() && !interrupted_;
}

std::vector<std::string> DatasetMirror::known() const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::string> out;
    for (const auto& [id, a] : announced_) out.push_back(id);
    for (const auto& [id, d] : local_) {
        if (!announced_.count(id)) out.push_back(id);
    }
    return out;
}

std::size_t DatasetMirror::files_fetched() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return fetched_;
}

fs::path DatasetMirror::dir_of(const std::string& dataset_id) const {
    if (auto it = local_.find(dataset_id); it != local_.end()) return it->second;
    return cache_root_ / dataset_id;
}

bool DatasetMirror::fetch(const std::string& dataset_id, const std::vector<std::string>& paths,
                          double timeout_s, std::string* error) {
    std::map<std::string, std::string> want;  // path -> hash
    fs::path dir;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (local_.count(dataset_id)) return true;
        const auto it = announced_.find(dataset_id);
        if (it == announced_.end()) {
            if (error) *error = "dataset " + dataset_id + " was not announced by any dataset_server";
            return false;
        }
        for (const auto& f : it->second.files()) want[f.path()] = f.hash();
        dir = dir_of(dataset_id);
    }
    // Start every missing transfer at once, then wait for all of them.
    std::map<std::string, std::string> started;  // request id -> path
    for (const auto& p : paths) {
        const auto it = want.find(p);
        if (it == want.end()) {
            if (error) *error = "'" + p + "' is not a file of dataset " + dataset_id;
            return false;
        }
        const fs::path local = dir / p;
        std::error_code ec;
        if (fs::exists(local, ec) &&
            dataset::hex64(dataset::fnv1a(dataset::read_file(local))) == it->second) {
            continue;  // cached and intact
        }
        v1::FileRequest r;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            r.request_id(client_id_ + "/" + std::to_string(next_request_++));
            transfers_[r.request_id()].path = p;
        }
        r.dataset_id(dataset_id);
        r.path(p);
        started[r.request_id()] = p;
        requests_.write(r);
    }
    bool ok = true;
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(timeout_s));
    for (const auto& [first_rid, path] : started) {
        Transfer t;
        std::string rid = first_rid;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            std::size_t seen = 0;
            bool done = false;
            for (;;) {
                // A transfer without a new chunk for kRetryS was lost (the dataset_server
                // restarted, or its reader had not matched our request): ask again under a new
                // id, so chunks of the lost one are never mixed in.
                const auto slice = std::min(deadline, std::chrono::steady_clock::now() + kRetry);
                done = cv_.wait_until(lock, slice,
                                      [&] { return transfers_[rid].done || stop_requested() || interrupted_; });
                if (done || stop_requested() || interrupted_ || std::chrono::steady_clock::now() >= deadline) break;
                if (transfers_[rid].received != seen) {
                    seen = transfers_[rid].received;
                    continue;
                }
                transfers_.erase(rid);
                v1::FileRequest again;
                again.request_id(client_id_ + "/" + std::to_string(next_request_++));
                again.dataset_id(dataset_id);
                again.path(path);
                rid = again.request_id();
                transfers_[rid].path = path;
                seen = 0;
                lock.unlock();  // a reliable write may wait for the DDS thread, which takes mutex_
                requests_.write(again);
                lock.lock();
            }
            t = std::move(transfers_[rid]);
            transfers_.erase(rid);
            if (!done || !t.done) {
                if (error) *error = "timed out fetching '" + path + "' of dataset " + dataset_id;
                ok = false;
                continue;
            }
        }
        if (!t.error.empty()) {
            if (error) *error = "dataset_server refused '" + path + "': " + t.error;
            ok = false;
            continue;
        }
        std::string bytes;
        for (const auto& c : t.chunks) bytes += c;
        if (dataset::hex64(dataset::fnv1a(bytes)) != want[path]) {
            if (error) *error = "'" + path + "' arrived corrupted (hash mismatch)";
            ok = false;
            continue;
        }
        fs::create_directories((dir / path).parent_path());
        dataset::write_file(dir / path, bytes);  // temp file + rename
        std::lock_guard<std::mutex> lock(mutex_);
        ++fetched_;
    }
    return ok;
}

std::optional<dataset::Dataset> DatasetMirror::open(const std::string& dataset_id, double timeout_s,
                                                    std::string* error) {
    if (!wait_for(dataset_id, timeout_s)) {
        if (error) *error = "dataset " + dataset_id + " is unknown (no dataset_server announced it)";
        return std::nullopt;
    }
    std::vector<std::string> meta;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (auto it = announced_.find(dataset_id); it != announced_.end() && !local_.count(dataset_id)) {
            for (const auto& f : it->second.files()) {
                if (!is_bulk_file(f.path())) meta.push_back(f.path());
            }
        }
    }
    if (!fetch(dataset_id, meta, timeout_s, error)) return std::nullopt;
    try {
        std::lock_guard<std::mutex> lock(mutex_);
        return dataset::Dataset::open(dir_of(dataset_id));
    } catch (const std::exception& e) {
        if (error) *error = e.what();
        return std::nullopt;
    }
}

bool DatasetMirror::ensure_submaps(const dataset::Dataset& ds, const std::vector<std::string>& submap_ids,
                                   double timeout_s, std::string* error) {
    std::set<std::string> ids(submap_ids.begin(), submap_ids.end());
    std::vector<std::string> paths;
    for (const auto& run : ds.manifest().runs) {
        for (const auto& s : run.submaps) {
            if (!ids.count(s.id)) continue;
            for (const std::string* p : {&s.cloud, &s.obstacles, &s.octomap}) {
                if (!p->empty()) paths.push_back(*p);
            }
        }
    }
    return fetch(ds.manifest().id, paths, timeout_s, error);
}

}  // namespace maptune::services
