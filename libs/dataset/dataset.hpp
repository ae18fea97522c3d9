#pragma once
// The dataset format (a directory with manifest.yaml), its writer and its loader, views of
// submap pairs with reference transforms, and the statistics `maptune dataset info` shows.
// Layout and derivations: docs/datasets.md.

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "dataset/io.hpp"
#include "dataset/submap.hpp"

namespace maptune::dataset {

inline constexpr int kFormatVersion = 1;

struct SubmapRecord {
    std::string id;            // "run03/submap012"
    std::string cloud;         // paths relative to the dataset directory
    std::string obstacles;
    std::string octomap;       // empty when the submap has none
    double timestamp = 0;      // seconds
    std::size_t points = 0;
    std::size_t obstacle_points = 0;
    double size = 0;           // distance from origin to farthest point [m]
};

struct PairOverlap {
    int a = 0, b = 0;          // submap indices within the run, a < b
    double overlap = 0;        // |A ∩ B| / min(|A|, |B|) of voxel sets in the gt world frame
};

struct RunRecord {
    std::string name;          // "run03"
    std::string gt_file, odometry_file;            // one pose per submap origin
    std::string gt_full_file, odometry_full_file;  // full-rate trajectories; may be empty
    std::string pairs_file;
    std::vector<SubmapRecord> submaps;
    std::vector<StampedPose> gt, odometry;         // loaded from the files
    std::vector<PairOverlap> pairs;                // all pairs a < b (the complete view)
};

struct Manifest {
    int format_version = kFormatVersion;
    std::string id;                                // content hash (hex)
    std::string name;
    std::string source;                            // "simulator" or "import"
    double voxel_size = 0;                         // cloud resolution [m]
    double overlap_voxel = 0;                      // leaf of the overlap ratio [m]
    std::map<std::string, std::string> meta;       // generator / import settings
    std::vector<RunRecord> runs;
    // FNV-1a 64 of each file (relative path) as written; what the id was computed from. A file
    // that no longer matches is refused when it is loaded (its results would be stored under
    // this id). Empty in datasets written before it was recorded.
    std::map<std::string, std::uint64_t> file_hashes;
};

enum class View { complete, subsequent };
enum class Reference { gt, odometry };
View parse_view(const std::string& s);            // throws std::invalid_argument
Reference parse_reference(const std::string& s);
const char* to_string(View v);
const char* to_string(Reference r);

// A view at a fidelity (multi-fidelity tuning, docs/optimizer.md): "<view>" is the whole
// view, "<view>/<k>" a fixed stratified subset of about 1/k of its pairs.
struct ViewSpec {
    View view = View::subsequent;
    int subset = 1;  // 1: the whole view
    std::string str() const;
};
ViewSpec parse_view_spec(const std::string& s);  // throws std::invalid_argument

struct SubmapPair {
    int run = 0;
    int a = 0, b = 0;
    std::string id_a, id_b;
    Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();  // pose of b in a's frame
    double overlap = 0;                                         // from ground truth
};

// The fixed subset of about 1/k of `pairs` (at least one pair) that "<view>/<k>" names. Built
// from whole submaps so that it needs the features of few: submaps join the subset one at a
// time, each run in turn (the run with the smallest share of its pairs selected first: every
// run is represented in proportion), and a pair is in when both its submaps are. Where a run
// starts differs by run (golden-ratio offsets), so the subset covers the whole length of the
// trajectories. A subsequent view grows contiguous stretches (n pairs need n + 1 submaps); a
// complete view spreads neighbouring submaps along the run, so near and far pairs both appear. Pairs
// keep their order in `pairs`; the same pairs always give the same subset.
std::vector<SubmapPair> stratified_subset(const std::vector<SubmapPair>& pairs, View view, int k);

// Writes a dataset into "<out>.tmp-<n>" and renames it to <out> in finish(), so an
// interrupted write never looks like a valid dataset. Runs may be written concurrently
// (one RunWriter per thread); their order in the manifest is their index.
class RunWriter;
class DatasetWriter {
public:
    // `overwrite`: replace an existing <out>; otherwise an existing <out> is an error.
    DatasetWriter(std::filesystem::path out, std::string name, std::string source,
                  double voxel_size, double overlap_voxel, bool overwrite = false);
    ~DatasetWriter();  // removes the temporary directory unless finished
    DatasetWriter(const DatasetWriter&) = delete;
    DatasetWriter& operator=(const DatasetWriter&) = delete;

    void set_meta(const std::string& key, const std::string& value);
    RunWriter run(int index);
    // Writes trajectories, pair overlaps and the manifest; returns the dataset id.
    std::string finish();

    const std::filesystem::path& temp_dir() const { return tmp_; }

private:
    friend class RunWriter;
    void add_file_hash(const std::string& rel, std::uint64_t h);
    void add_run(int index, RunRecord run);

    std::filesystem::path out_, tmp_;
    Manifest manifest_;
    bool overwrite_ = false, finished_ = false;
    std::mutex mutex_;
    std::map<std::string, std::uint64_t> file_hashes_;
    std::map<int, RunRecord> runs_;
};

class RunWriter {
public:
    // Writes the submap's files now; only a small voxel key set is kept for overlaps.
    void add_submap(const Submap& submap, double timestamp);
    // Optional full-rate trajectories (for plots).
    void set_full_trajectories(std::vector<StampedPose> gt, std::vector<StampedPose> odometry);
    // Computes the pair overlaps and hands the run to the dataset writer.
    void finish();
    std::size_t size() const { return record_.submaps.size(); }

private:
    friend class DatasetWriter;
    RunWriter(DatasetWriter& w, int index);
    std::string write(const std::string& rel, const std::string& bytes);

    DatasetWriter* writer_;
    int index_;
    RunRecord record_;
    std::vector<std::vector<std::uint64_t>> keys_;
    std::vector<StampedPose> gt_full_, odom_full_;
};

class Dataset {
public:
    // Reads and checks manifest.yaml and the trajectories / pair files it lists.
    static Dataset open(const std::filesystem::path& dir);

    const Manifest& manifest() const { return manifest_; }
    const std::filesystem::path& dir() const { return dir_; }
    std::size_t num_submaps() const;

    std::vector<SubmapPair> pairs(View view, Reference reference) const;
    // The pairs of a view at a fidelity: stratified_subset of the view's pairs for "<view>/<k>".
    std::vector<SubmapPair> pairs(const ViewSpec& view, Reference reference) const;
    // Overlap of each pair (|A ∩ B| / min(|A|, |B|) of voxel sets at the manifest's
    // overlap_voxel) with both clouds placed by the `reference` poses. gt: the stored values.
    // odometry: computed from the clouds and odometry poses only — what a robot without
    // ground truth knows (it reads the cloud of every submap of `pairs`).
    std::vector<double> reference_overlaps(const std::vector<SubmapPair>& pairs, Reference reference) const;
    // Loads clouds, obstacles and OctoMap; throws DatasetError on bad files.
    Submap load_submap(int run, int index) const;
    Submap load_submap(const std::string& id) const;
    // (run, index) of the submap with this id, from an index built by open().
    std::optional<std::pair<int, int>> locate(const std::string& id) const;
    // Pose of submap b in submap a's frame (both of one run) under the reference's poses.
    Eigen::Isometry3d relative_pose(int run, int a, int b, Reference reference) const;
    // Recomputes the content hash from the files; true when it matches the manifest's id.
    // `file_hashes` (relative path -> FNV-1a 64 of the content), when the caller already
    // hashed the files, spares reading them again.
    bool verify(std::string* recomputed = nullptr,
                const std::map<std::string, std::uint64_t>* file_hashes = nullptr) const;

private:
    std::filesystem::path dir_;
    Manifest manifest_;
    std::map<std::string, std::pair<int, int>> index_;  // submap id -> (run, index)
};

struct MeanStd {
    double mean = 0, std = 0, min = 0, max = 0;
    std::size_t n = 0;
};
MeanStd mean_std(const std::vector<double>& v);

struct DatasetStats {
    std::size_t runs = 0, submaps = 0;
    MeanStd submaps_per_run, points_per_submap, obstacles_per_submap, submap_size;
    std::size_t complete_pairs = 0;
    double overlapping_fraction = 0;     // overlap > overlap_threshold
    double overlap_threshold = 0.1;
    MeanStd subsequent_overlap;
    // Odometry vs ground truth of the transforms between subsequent submap origins.
    MeanStd odom_translation_error;      // [m]
    MeanStd odom_rotation_error;         // [rad]
};
DatasetStats compute_stats(const Dataset& ds, double overlap_threshold = 0.1);
std::string format_stats(const Dataset& ds, const DatasetStats& s);

}  // namespace maptune::dataset
