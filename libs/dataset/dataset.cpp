#include "dataset/dataset.hpp"

#include <octomap/OcTree.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "dataset/geometry.hpp"

namespace maptune::dataset {
namespace fs = std::filesystem;

View parse_view(const std::string& s) {
    if (s == "complete") return View::complete;
    if (s == "subsequent") return View::subsequent;
    throw std::invalid_argument("unknown view '" + s + "' (complete|subsequent)");
}
Reference parse_reference(const std::string& s) {
    if (s == "gt") return Reference::gt;
    if (s == "odometry" || s == "odom") return Reference::odometry;
    throw std::invalid_argument("unknown reference '" + s + "' (gt|odometry)");
}
const char* to_string(View v) { return v == View::complete ? "complete" : "subsequent"; }
const char* to_string(Reference r) { return r == Reference::gt ? "gt" : "odometry"; }

std::string ViewSpec::str() const {
    return subset > 1 ? std::string(to_string(view)) + "/" + std::to_string(subset) : to_string(view);
}

ViewSpec parse_view_spec(const std::string& s) {
    const auto slash = s.find('/');
    ViewSpec spec;
    spec.view = parse_view(s.substr(0, slash));
    if (slash == std::string::npos) return spec;
    const std::string k = s.substr(slash + 1);
    // Digits only, 2..1000000: "subsequent/1" would name the whole view under another key.
    const bool digits = !k.empty() && k.size() <= 7 && k.find_first_not_of("0123456789") == std::string::npos;
    spec.subset = digits ? std::stoi(k) : 0;
    if (spec.subset < 2) {
        throw std::invalid_argument("view '" + s + "': the subset after '/' must be an integer k >= 2 (about 1/k of the pairs)");
    }
    return spec;
}

std::vector<SubmapPair> stratified_subset(const std::vector<SubmapPair>& pairs, View view, int k) {
    if (k <= 1 || pairs.empty()) return pairs;
    const std::size_t target = std::max<std::size_t>(1, (pairs.size() + static_cast<std::size_t>(k) - 1) /
                                                            static_cast<std::size_t>(k));
    struct RunState {
        std::vector<int> order;                          // submaps in the order they join
        std::map<int, std::vector<std::size_t>> touching;  // submap -> pairs (indices into `pairs`)
        std::set<int> chosen;
        std::size_t next = 0, selected = 0, total = 0;
    };
    std::map<int, RunState> runs;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        RunState& r = runs[pairs[i].run];
        r.touching[pairs[i].a].push_back(i);
        r.touching[pairs[i].b].push_back(i);
        ++r.total;
    }
    for (auto& [run, r] : runs) {
        std::vector<int> submaps;
        for (const auto& t : r.touching) submaps.push_back(t.first);
        const std::size_t n = submaps.size();
        const double golden = 0.6180339887498949;
        const double phase = std::fmod((run + 1) * golden, 1.0);
        const auto start = std::min(n - 1, static_cast<std::size_t>(phase * static_cast<double>(n)));
        if (view == View::subsequent) {
            // Forwards from the start, then backwards from it: one contiguous stretch.
            for (std::size_t j = start; j < n; ++j) r.order.push_back(submaps[j]);
            for (std::size_t j = start; j-- > 0;) r.order.push_back(submaps[j]);
        } else {
            // Two neighbours at van der Corput positions shifted by the phase: spread along the
            // run at every size, with the nearest pairs (the most overlap) among the far ones.
            std::vector<bool> used(n, false);
            for (std::uint32_t j = 0; r.order.size() < n && j < 64 * n; ++j) {
                double u = 0, f = 0.5;
                for (std::uint32_t b = j; b; b >>= 1, f *= 0.5) u += (b & 1) * f;
                const auto pos = std::min(n - 1, static_cast<std::size_t>(std::fmod(u + phase, 1.0) * static_cast<double>(n)));
                for (const std::size_t q : {pos, pos + 1 < n ? pos + 1 : pos - 1}) {
                    if (q < n && !used[q]) {
                        used[q] = true;
                        r.order.push_back(submaps[q]);
                    }
                }
            }
            for (std::size_t j = 0; j < n; ++j) {
                if (!used[j]) r.order.push_back(submaps[j]);
            }
        }
    }
    std::vector<bool> in(pairs.size(), false);
    std::size_t selected = 0;
    while (selected < target) {
        // The run furthest behind its share; fewer chosen submaps, then the lower run, break ties.
        RunState* pick = nullptr;
        for (auto& [run, r] : runs) {
            if (r.next >= r.order.size()) continue;
            if (pick == nullptr) {
                pick = &r;
                continue;
            }
            const double share = static_cast<double>(r.selected) / static_cast<double>(r.total);
            const double best = static_cast<double>(pick->selected) / static_cast<double>(pick->total);
            if (share < best || (share == best && r.chosen.size() < pick->chosen.size())) pick = &r;
        }
        if (pick == nullptr) break;
        const int s = pick->order[pick->next++];
        pick->chosen.insert(s);
        for (const std::size_t i : pick->touching[s]) {
            const int other = pairs[i].a == s ? pairs[i].b : pairs[i].a;
            if (!in[i] && pick->chosen.count(other)) {
                in[i] = true;
                ++pick->selected;
                ++selected;
            }
        }
    }
    std::vector<SubmapPair> out;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        if (in[i]) out.push_back(pairs[i]);
    }
    return out;
}

namespace {

std::string fmt(double v) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.9g", v);
    return buf;
}

std::string quote(const std::string& s) {
    std::string o = "\"";
    for (char c : s) {
        if (c == '"' || c == '\\') o += '\\';
        o += c;
    }
    return o + "\"";
}

std::string manifest_body(const Manifest& m) {
    std::ostringstream y;
    y << "format: maptune-dataset\n";
    y << "format_version: " << m.format_version << "\n";
    y << "name: " << quote(m.name) << "\n";
    y << "source: " << quote(m.source) << "\n";
    y << "voxel_size: " << fmt(m.voxel_size) << "\n";
    y << "overlap_voxel: " << fmt(m.overlap_voxel) << "\n";
    y << "meta:\n";
    for (const auto& [k, v] : m.meta) y << "  " << k << ": " << quote(v) << "\n";
    if (m.meta.empty()) y << "  {}\n";
    y << "runs:\n";
    for (const auto& r : m.runs) {
        y << "  - name: " << quote(r.name) << "\n";
        y << "    gt: " << quote(r.gt_file) << "\n";
        y << "    odometry: " << quote(r.odometry_file) << "\n";
        if (!r.gt_full_file.empty()) y << "    gt_full: " << quote(r.gt_full_file) << "\n";
        if (!r.odometry_full_file.empty()) {
            y << "    odometry_full: " << quote(r.odometry_full_file) << "\n";
        }
        y << "    pairs: " << quote(r.pairs_file) << "\n";
        y << "    submaps:\n";
        for (const auto& s : r.submaps) {
            y << "      - {id: " << quote(s.id) << ", cloud: " << quote(s.cloud)
              << ", obstacles: " << quote(s.obstacles) << ", octomap: " << quote(s.octomap)
              << ", points: " << s.points << ", obstacle_points: " << s.obstacle_points
              << ", size: " << fmt(s.size) << "}\n";
        }
    }
    return y.str();
}

std::string format_pairs(const std::vector<PairOverlap>& pairs) {
    std::ostringstream ss;
    ss << "# a b overlap_gt\n";
    char buf[64];
    for (const auto& p : pairs) {
        std::snprintf(buf, sizeof(buf), "%d %d %.4f\n", p.a, p.b, p.overlap);
        ss << buf;
    }
    return ss.str();
}

std::vector<PairOverlap> read_pairs(const fs::path& file, int n) {
    std::istringstream in(read_file(file));
    std::vector<PairOverlap> out;
    std::string line;
    int line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        if (line.empty() || line[0] == '#') continue;
        std::istringstream ls(line);
        PairOverlap p;
        if (!(ls >> p.a >> p.b >> p.overlap) || p.a < 0 || p.b <= p.a || p.b >= n || !(p.overlap >= 0) ||
            p.overlap > 1) {
            throw DatasetError(file, "line " + std::to_string(line_no) +
                                         ": expected 'a b overlap' with 0 <= a < b < " +
                                         std::to_string(n) + " and overlap in [0, 1]");
        }
        out.push_back(p);
    }
    if (out.size() != static_cast<std::size_t>(n) * (n - 1) / 2) {
        throw DatasetError(file, "expected " + std::to_string(n * (n - 1) / 2) +
                                     " pairs for " + std::to_string(n) + " submaps, found " +
                                     std::to_string(out.size()));
    }
    return out;
}

std::uint64_t content_hash(const std::string& body,
                           const std::map<std::string, std::uint64_t>& files) {
    std::uint64_t h = fnv1a(body);
    for (const auto& [path, fh] : files) h = fnv1a(path + ":" + hex64(fh) + "\n", h);
    return h;
}

std::atomic<int> g_tmp_counter{0};

// --force replaces only what a previous generate/import wrote: never the current directory
// or one that holds it, never a file, never a directory of something else.
void check_replaceable(const fs::path& out) {
    std::error_code ec;
    const fs::path cwd = fs::current_path(ec).lexically_normal();
    const auto rel = cwd.lexically_relative(out);
    if (out == out.root_path() || (!ec && !rel.empty() && *rel.begin() != "..")) {
        throw DatasetError(out, "refusing to replace it: it is or holds the current directory");
    }
    if (!fs::is_directory(out)) throw DatasetError(out, "refusing to replace it: not a directory");
    if (fs::is_empty(out, ec)) return;
    if (!fs::is_regular_file(out / "manifest.yaml")) {
        throw DatasetError(out, "refusing to replace it: not a maptune dataset (no manifest.yaml); "
                                "--force replaces only a previous dataset");
    }
}

}  // namespace

// ------------------------------------------------------------------ writer

DatasetWriter::DatasetWriter(fs::path out, std::string name, std::string source,
                             double voxel_size, double overlap_voxel, bool overwrite)
    : out_(std::move(out)), overwrite_(overwrite) {
    std::error_code ec;
    out_ = fs::absolute(out_, ec).lexically_normal();
    if (out_.has_filename() == false) out_ = out_.parent_path();
    if (fs::exists(out_) && !overwrite_) {
        throw DatasetError(out_, "output already exists (choose another --out or pass --force)");
    }
    if (fs::exists(out_)) check_replaceable(out_);
    tmp_ = out_.string() + ".tmp-" + std::to_string(::getpid()) + "-" +
           std::to_string(g_tmp_counter++);
    fs::remove_all(tmp_, ec);
    fs::create_directories(tmp_, ec);
    if (ec) throw DatasetError(tmp_, "cannot create directory: " + ec.message());
    manifest_.name = std::move(name);
    manifest_.source = std::move(source);
    manifest_.voxel_size = voxel_size;
    manifest_.overlap_voxel = overlap_voxel;
}

DatasetWriter::~DatasetWriter() {
    if (!finished_) {
        std::error_code ec;
        fs::remove_all(tmp_, ec);
    }
}

void DatasetWriter::set_meta(const std::string& key, const std::string& value) {
    std::lock_guard<std::mutex> lock(mutex_);
    manifest_.meta[key] = value;
}

RunWriter DatasetWriter::run(int index) { return RunWriter(*this, index); }

void DatasetWriter::add_file_hash(const std::string& rel, std::uint64_t h) {
    std::lock_guard<std::mutex> lock(mutex_);
    file_hashes_[rel] = h;
}

void DatasetWriter::add_run(int index, RunRecord run) {
    std::lock_guard<std::mutex> lock(mutex_);
    runs_[index] = std::move(run);
}

std::string DatasetWriter::finish() {
    manifest_.runs.clear();
    for (auto& [i, r] : runs_) manifest_.runs.push_back(std::move(r));
    if (manifest_.runs.empty()) throw DatasetError(out_, "refusing to write a dataset without runs");
    const std::string body = manifest_body(manifest_);
    manifest_.id = hex64(content_hash(body, file_hashes_));
    manifest_.file_hashes = file_hashes_;
    // The per-file hashes follow the body: the id is computed from the body and them, as before.
    std::string files = "files:\n";
    for (const auto& [rel, h] : file_hashes_) files += "  \"" + rel + "\": \"" + hex64(h) + "\"\n";
    write_file(tmp_ / "manifest.yaml", "id: \"" + manifest_.id + "\"\n" + body + files);
    std::error_code ec;
    if (fs::exists(out_)) fs::remove_all(out_, ec);
    fs::rename(tmp_, out_, ec);
    if (ec) throw DatasetError(out_, "cannot move finished dataset into place: " + ec.message());
    finished_ = true;
    return manifest_.id;
}

RunWriter::RunWriter(DatasetWriter& w, int index) : writer_(&w), index_(index) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "run%02d", index);
    record_.name = buf;
    fs::create_directories(w.tmp_ / record_.name);
}

std::string RunWriter::write(const std::string& rel, const std::string& bytes) {
    write_file(writer_->tmp_ / rel, bytes);
    writer_->add_file_hash(rel, fnv1a(bytes));
    return rel;
}

void RunWriter::add_submap(const Submap& submap, double timestamp) {
    if (submap.cloud.empty()) {
        throw DatasetError(record_.name, "submap " + std::to_string(record_.submaps.size()) +
                                             " has an empty cloud");
    }
    char buf[64];
    std::snprintf(buf, sizeof(buf), "submap%03zu", record_.submaps.size());
    const std::string base = record_.name + "/" + buf;
    SubmapRecord s;
    s.id = base;
    s.timestamp = timestamp;
    s.cloud = write(base + ".pcd", format_pcd_xyzrgb(submap.cloud));
    s.obstacles = write(base + "_obstacles.pcd", format_pcd_xyz(submap.obstacles));
    if (submap.octree) {
        s.octomap = write(base + ".bt", octree_to_bt(*submap.octree));
    }
    s.points = submap.cloud.size();
    s.obstacle_points = submap.obstacles.size();
    s.size = submap_size(submap.cloud);
    record_.submaps.push_back(s);
    StampedPose g{timestamp, submap.T_world_submap_gt}, o{timestamp, submap.T_world_submap_odom};
    record_.gt.push_back(g);
    record_.odometry.push_back(o);
    keys_.push_back(world_voxel_keys(submap.cloud, submap.T_world_submap_gt,
                                     static_cast<float>(writer_->manifest_.overlap_voxel)));
}

void RunWriter::set_full_trajectories(std::vector<StampedPose> gt, std::vector<StampedPose> odometry) {
    gt_full_ = std::move(gt);
    odom_full_ = std::move(odometry);
}

void RunWriter::finish() {
    const std::string& n = record_.name;
    record_.gt_file = write(n + "/gt.tum", format_tum(record_.gt));
    record_.odometry_file = write(n + "/odometry.tum", format_tum(record_.odometry));
    if (!gt_full_.empty()) {
        record_.gt_full_file = write(n + "/gt_full.tum", format_tum(gt_full_));
        record_.odometry_full_file = write(n + "/odometry_full.tum", format_tum(odom_full_));
    }
    const int k = static_cast<int>(keys_.size());
    for (int a = 0; a < k; ++a) {
        for (int b = a + 1; b < k; ++b) {
            record_.pairs.push_back(PairOverlap{a, b, overlap_ratio(keys_[a], keys_[b])});
        }
    }
    record_.pairs_file = write(n + "/pairs.txt", format_pairs(record_.pairs));
    keys_.clear();
    writer_->add_run(index_, std::move(record_));
}

// ------------------------------------------------------------------ loader

namespace {

template <typename T>
T get(const YAML::Node& node, const char* key, const fs::path& file, const std::string& where) {
    const YAML::Node v = node[key];
    if (!v) throw DatasetError(file, where + "." + key + ": missing");
    try {
        return v.as<T>();
    } catch (const YAML::Exception&) {
        throw DatasetError(file, where + "." + key + ": wrong type");
    }
}

}  // namespace

Dataset Dataset::open(const fs::path& dir) {
    Dataset ds;
    ds.dir_ = dir;
    const fs::path mf = dir / "manifest.yaml";
    if (!fs::is_directory(dir)) throw DatasetError(dir, "not a dataset directory (missing)");
    if (!fs::exists(mf)) throw DatasetError(mf, "missing manifest (not a dataset, or unfinished)");
    YAML::Node root;
    try {
        root = YAML::Load(read_file(mf));
    } catch (const YAML::Exception& e) {
        throw DatasetError(mf, std::string("invalid YAML: ") + e.what());
    }
    Manifest& m = ds.manifest_;
    if (!root.IsMap() || !root["format"] || root["format"].as<std::string>() != "maptune-dataset") {
        throw DatasetError(mf, "not a maptune dataset manifest (format: maptune-dataset)");
    }
    m.format_version = get<int>(root, "format_version", mf, "");
    if (m.format_version != kFormatVersion) {
        throw DatasetError(mf, "unsupported format_version " + std::to_string(m.format_version));
    }
    m.id = get<std::string>(root, "id", mf, "");
    m.name = get<std::string>(root, "name", mf, "");
    m.source = get<std::string>(root, "source", mf, "");
    m.voxel_size = get<double>(root, "voxel_size", mf, "");
    m.overlap_voxel = get<double>(root, "overlap_voxel", mf, "");
    // Both are divisors (voxel keys): zero, negative or NaN would hang or divide by zero later.
    if (!(m.voxel_size > 0) || !std::isfinite(m.voxel_size)) {
        throw DatasetError(mf, "voxel_size: " + std::to_string(m.voxel_size) + " is not a positive number");
    }
    if (!(m.overlap_voxel > 0) || !std::isfinite(m.overlap_voxel)) {
        throw DatasetError(mf, "overlap_voxel: " + std::to_string(m.overlap_voxel) + " is not a positive number");
    }
    if (root["meta"] && root["meta"].IsMap()) {
        for (const auto& kv : root["meta"]) {
            if (!kv.first.IsScalar() || !kv.second.IsScalar()) throw DatasetError(mf, "meta: expected name: text entries");
            m.meta[kv.first.as<std::string>()] = kv.second.as<std::string>();
        }
    }
    if (root["files"]) {
        if (!root["files"].IsMap()) throw DatasetError(mf, "files: expected path: hash entries");
        for (const auto& kv : root["files"]) {
            const std::string rel = kv.first.IsScalar() ? kv.first.as<std::string>() : "";
            const std::string hex = kv.second.IsScalar() ? kv.second.as<std::string>() : "";
            if (rel.empty() || hex.size() != 16 || hex.find_first_not_of("0123456789abcdef") != std::string::npos) {
                throw DatasetError(mf, "files: expected path: 16 hex digits, got '" + rel + "': '" + hex + "'");
            }
            m.file_hashes[rel] = std::stoull(hex, nullptr, 16);
        }
    }
    const YAML::Node runs = root["runs"];
    if (!runs || !runs.IsSequence() || runs.size() == 0) throw DatasetError(mf, "runs: missing or empty");
    for (std::size_t i = 0; i < runs.size(); ++i) {
        const std::string where = "runs[" + std::to_string(i) + "]";
        const YAML::Node rn = runs[i];
        RunRecord r;
        r.name = get<std::string>(rn, "name", mf, where);
        r.gt_file = get<std::string>(rn, "gt", mf, where);
        r.odometry_file = get<std::string>(rn, "odometry", mf, where);
        if (rn["gt_full"]) r.gt_full_file = rn["gt_full"].as<std::string>();
        if (rn["odometry_full"]) r.odometry_full_file = rn["odometry_full"].as<std::string>();
        r.pairs_file = get<std::string>(rn, "pairs", mf, where);
        const YAML::Node sm = rn["submaps"];
        if (!sm || !sm.IsSequence() || sm.size() == 0) throw DatasetError(mf, where + ".submaps: missing or empty");
        for (std::size_t j = 0; j < sm.size(); ++j) {
            const std::string w2 = where + ".submaps[" + std::to_string(j) + "]";
            SubmapRecord s;
            s.id = get<std::string>(sm[j], "id", mf, w2);
            s.cloud = get<std::string>(sm[j], "cloud", mf, w2);
            s.obstacles = get<std::string>(sm[j], "obstacles", mf, w2);
            s.octomap = get<std::string>(sm[j], "octomap", mf, w2);
            s.points = get<std::size_t>(sm[j], "points", mf, w2);
            s.obstacle_points = get<std::size_t>(sm[j], "obstacle_points", mf, w2);
            s.size = get<double>(sm[j], "size", mf, w2);
            r.submaps.push_back(s);
        }
        r.gt = read_tum(dir / r.gt_file);
        r.odometry = read_tum(dir / r.odometry_file);
        const std::size_t n = r.submaps.size();
        if (r.gt.size() != n) {
            throw DatasetError(dir / r.gt_file, std::to_string(r.gt.size()) + " poses for " +
                                                    std::to_string(n) + " submaps");
        }
        if (r.odometry.size() != n) {
            throw DatasetError(dir / r.odometry_file, std::to_string(r.odometry.size()) +
                                                          " poses for " + std::to_string(n) + " submaps");
        }
        for (std::size_t j = 0; j < n; ++j) r.submaps[j].timestamp = r.gt[j].timestamp;
        r.pairs = read_pairs(dir / r.pairs_file, static_cast<int>(n));
        m.runs.push_back(std::move(r));
    }
    for (std::size_t ri = 0; ri < m.runs.size(); ++ri) {
        for (std::size_t j = 0; j < m.runs[ri].submaps.size(); ++j)
            ds.index_[m.runs[ri].submaps[j].id] = {static_cast<int>(ri), static_cast<int>(j)};
    }
    return ds;
}

std::size_t Dataset::num_submaps() const {
    std::size_t n = 0;
    for (const auto& r : manifest_.runs) n += r.submaps.size();
    return n;
}

std::vector<SubmapPair> Dataset::pairs(View view, Reference reference) const {
    std::vector<SubmapPair> out;
    for (std::size_t ri = 0; ri < manifest_.runs.size(); ++ri) {
        const RunRecord& r = manifest_.runs[ri];
        for (const auto& p : r.pairs) {
            if (view == View::subsequent && p.b != p.a + 1) continue;
            SubmapPair sp;
            sp.run = static_cast<int>(ri);
            sp.a = p.a;
            sp.b = p.b;
            sp.id_a = r.submaps[p.a].id;
            sp.id_b = r.submaps[p.b].id;
            sp.T_a_b = relative_pose(static_cast<int>(ri), p.a, p.b, reference);
            sp.overlap = p.overlap;
            out.push_back(sp);
        }
    }
    return out;
}

std::vector<SubmapPair> Dataset::pairs(const ViewSpec& view, Reference reference) const {
    return stratified_subset(pairs(view.view, reference), view.view, view.subset);
}

std::vector<double> Dataset::reference_overlaps(const std::vector<SubmapPair>& pairs,
                                                Reference reference) const {
    std::vector<double> out;
    out.reserve(pairs.size());
    if (reference == Reference::gt) {
        for (const auto& p : pairs) out.push_back(p.overlap);
        return out;
    }
    std::map<std::pair<int, int>, std::vector<std::uint64_t>> keys;  // per submap, by odometry
    auto keys_of = [&](int run, int index) -> const std::vector<std::uint64_t>& {
        const auto [it, inserted] = keys.try_emplace({run, index});
        if (inserted) {  // each cloud read once
            const RunRecord& r = manifest_.runs.at(static_cast<std::size_t>(run));
            const SubmapRecord& s = r.submaps.at(static_cast<std::size_t>(index));
            it->second = world_voxel_keys(read_cloud(dir_ / s.cloud), r.odometry.at(static_cast<std::size_t>(index)).T,
                                          static_cast<float>(manifest_.overlap_voxel));
        }
        return it->second;
    };
    for (const auto& p : pairs) out.push_back(overlap_ratio(keys_of(p.run, p.a), keys_of(p.run, p.b)));
    return out;
}

Submap Dataset::load_submap(int run, int index) const {
    if (run < 0 || run >= static_cast<int>(manifest_.runs.size())) {
        throw DatasetError(dir_, "no run " + std::to_string(run));
    }
    const RunRecord& r = manifest_.runs[run];
    if (index < 0 || index >= static_cast<int>(r.submaps.size())) {
        throw DatasetError(dir_, "run " + r.name + " has no submap " + std::to_string(index));
    }
    const SubmapRecord& s = r.submaps[index];
    Submap out;
    out.id = s.id;
    out.cloud = read_cloud(dir_ / s.cloud);
    if (out.cloud.size() != s.points) {
        throw DatasetError(dir_ / s.cloud, "has " + std::to_string(out.cloud.size()) +
                                               " points, manifest says " + std::to_string(s.points));
    }
    out.obstacles = read_points(dir_ / s.obstacles);
    // Each file hashed once: checked against the manifest (a changed file would give results
    // that the store keeps under this dataset's id), then folded into the submap's content hash.
    std::uint64_t h = fnv1a("");
    auto add = [&](const std::string& rel, const std::string& bytes) {
        const std::uint64_t fh = fnv1a(bytes);
        if (const auto it = manifest_.file_hashes.find(rel); it != manifest_.file_hashes.end() && fh != it->second) {
            throw DatasetError(dir_ / rel, "changed since the dataset was written (hash " + hex64(fh) +
                                               ", manifest " + hex64(it->second) +
                                               "): regenerate or re-import the dataset");
        }
        h = fnv1a(hex64(fh), h);
    };
    add(s.cloud, read_file(dir_ / s.cloud));
    add(s.obstacles, read_file(dir_ / s.obstacles));
    if (!s.octomap.empty()) {
        const fs::path bt = dir_ / s.octomap;
        if (!fs::exists(bt)) throw DatasetError(bt, "missing OctoMap file");
        const std::string bytes = read_file(bt);  // parsed and hashed from one read
        add(s.octomap, bytes);
        out.octree = octree_from_bt(bytes, bt.string());
    }
    out.content_hash = h;
    out.T_world_submap_gt = r.gt[index].T;
    out.T_world_submap_odom = r.odometry[index].T;
    return out;
}

Submap Dataset::load_submap(const std::string& id) const {
    if (const auto at = locate(id)) return load_submap(at->first, at->second);
    throw DatasetError(dir_, "no submap with id '" + id + "'");
}

std::optional<std::pair<int, int>> Dataset::locate(const std::string& id) const {
    const auto it = index_.find(id);
    if (it == index_.end()) return std::nullopt;
    return it->second;
}

Eigen::Isometry3d Dataset::relative_pose(int run, int a, int b, Reference reference) const {
    const RunRecord& r = manifest_.runs[static_cast<std::size_t>(run)];
    const auto& poses = reference == Reference::gt ? r.gt : r.odometry;
    return poses[static_cast<std::size_t>(a)].T.inverse() * poses[static_cast<std::size_t>(b)].T;
}

bool Dataset::verify(std::string* recomputed, const std::map<std::string, std::uint64_t>* file_hashes) const {
    const std::string text = read_file(dir_ / "manifest.yaml");
    std::string body = text.substr(text.find('\n') + 1);
    // The per-file hashes at the end are not part of what the id hashes.
    if (const auto f = body.rfind("\nfiles:\n"); f != std::string::npos) body.resize(f + 1);
    std::map<std::string, std::uint64_t> files;
    auto add = [&](const std::string& rel) {
        if (rel.empty()) return;
        if (file_hashes) {
            if (const auto it = file_hashes->find(rel); it != file_hashes->end()) {
                files[rel] = it->second;
                return;
            }
        }
        files[rel] = fnv1a(read_file(dir_ / rel));
    };
    for (const auto& r : manifest_.runs) {
        add(r.gt_file);
        add(r.odometry_file);
        add(r.gt_full_file);
        add(r.odometry_full_file);
        add(r.pairs_file);
        for (const auto& s : r.submaps) {
            add(s.cloud);
            add(s.obstacles);
            add(s.octomap);
        }
    }
    const std::string id = hex64(content_hash(body, files));
    if (recomputed) *recomputed = id;
    return id == manifest_.id;
}

// ------------------------------------------------------------------ stats

MeanStd mean_std(const std::vector<double>& v) {
    MeanStd s;
    s.n = v.size();
    if (v.empty()) return s;
    double sum = 0;
    s.min = v[0];
    s.max = v[0];
    for (double x : v) {
        sum += x;
        s.min = std::min(s.min, x);
        s.max = std::max(s.max, x);
    }
    s.mean = sum / v.size();
    double var = 0;
    for (double x : v) var += (x - s.mean) * (x - s.mean);
    s.std = v.size() > 1 ? std::sqrt(var / (v.size() - 1)) : 0;
    return s;
}

DatasetStats compute_stats(const Dataset& ds, double overlap_threshold) {
    DatasetStats s;
    const Manifest& m = ds.manifest();
    s.runs = m.runs.size();
    s.overlap_threshold = overlap_threshold;
    std::vector<double> per_run, points, obstacles, sizes, sub_overlap, et, er;
    std::size_t overlapping = 0;
    for (const auto& r : m.runs) {
        per_run.push_back(static_cast<double>(r.submaps.size()));
        for (const auto& sm : r.submaps) {
            points.push_back(static_cast<double>(sm.points));
            obstacles.push_back(static_cast<double>(sm.obstacle_points));
            sizes.push_back(sm.size);
        }
        for (const auto& p : r.pairs) {
            ++s.complete_pairs;
            if (p.overlap > overlap_threshold) ++overlapping;
            if (p.b == p.a + 1) sub_overlap.push_back(p.overlap);
        }
        for (std::size_t i = 0; i + 1 < r.submaps.size(); ++i) {
            const Eigen::Isometry3d g = r.gt[i].T.inverse() * r.gt[i + 1].T;
            const Eigen::Isometry3d o = r.odometry[i].T.inverse() * r.odometry[i + 1].T;
            et.push_back((o.translation() - g.translation()).norm());
            er.push_back(Eigen::AngleAxisd(g.linear().transpose() * o.linear()).angle());
        }
    }
    s.submaps = points.size();
    s.submaps_per_run = mean_std(per_run);
    s.points_per_submap = mean_std(points);
    s.obstacles_per_submap = mean_std(obstacles);
    s.submap_size = mean_std(sizes);
    s.overlapping_fraction = s.complete_pairs ? double(overlapping) / s.complete_pairs : 0;
    s.subsequent_overlap = mean_std(sub_overlap);
    s.odom_translation_error = mean_std(et);
    s.odom_rotation_error = mean_std(er);
    return s;
}

std::string format_stats(const Dataset& ds, const DatasetStats& s) {
    std::ostringstream o;
    char buf[256];
    auto line = [&](const char* label, const MeanStd& v, double scale, const char* unit) {
        std::snprintf(buf, sizeof(buf), "%-34s mean %.4g  std %.4g  min %.4g  max %.4g %s\n", label,
                      v.mean * scale, v.std * scale, v.min * scale, v.max * scale, unit);
        o << buf;
    };
    const Manifest& m = ds.manifest();
    o << "dataset " << m.name << "  id " << m.id << "  (" << m.source << ", " << ds.dir().string() << ")\n";
    o << "runs " << s.runs << ", submaps " << s.submaps << ", voxel " << m.voxel_size << " m\n";
    line("submaps per run", s.submaps_per_run, 1, "");
    line("points per submap", s.points_per_submap, 1, "");
    line("obstacle points per submap", s.obstacles_per_submap, 1, "");
    line("submap size d [m]", s.submap_size, 1, "m");
    std::snprintf(buf, sizeof(buf), "%-34s %zu, of which %.1f %% overlap > %.2f (gt)\n",
                  "complete pairs", s.complete_pairs, 100 * s.overlapping_fraction, s.overlap_threshold);
    o << buf;
    line("subsequent-pair overlap", s.subsequent_overlap, 1, "");
    line("odometry error subsequent, transl.", s.odom_translation_error, 100, "cm");
    line("odometry error subsequent, rot.", s.odom_rotation_error, 180 / M_PI, "deg");
    return o.str();
}

}  // namespace maptune::dataset
