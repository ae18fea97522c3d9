#pragma once
// Import of real scans: clouds (PCD/PLY) with one pose each -> a dataset of one run.
// Derivations when the input lacks them (docs/datasets.md):
//  - OctoMap: rays from the sensor origin (in each cloud's own frame) to every point of
//    the voxel-filtered cloud; free along the ray, occupied at the end;
//  - obstacle points: curvature (surface variation) or, for gravity-aligned ground-robot
//    data, height steps / slopes / negative edges.

#include <Eigen/Geometry>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "dataset/io.hpp"

namespace maptune::dataset {

struct ImportInput {
    std::vector<std::filesystem::path> clouds;     // one submap each, in the cloud's frame
    std::vector<StampedPose> poses;                // T_world_cloud (ground truth), one per cloud
    std::vector<StampedPose> odometry;             // optional; defaults to `poses`
    std::vector<std::filesystem::path> obstacles;  // optional, one per cloud
    std::vector<std::filesystem::path> octomaps;   // optional .bt, one per cloud
};

struct ImportOptions {
    std::string name = "import";
    double voxel_m = 0.05;                 // cloud resolution
    double octomap_resolution_m = 0.1;
    double max_range_m = -1;               // OctoMap ray length limit; <= 0 unlimited
    Eigen::Vector3f sensor_origin = Eigen::Vector3f::Zero();  // in each cloud's frame
    std::string obstacle_method = "curvature";  // curvature | height
    double curvature_radius_m = 0.15;
    double curvature_threshold = 0.06;
    bool drop_nan = false;
    bool overwrite = false;
    std::map<std::string, std::string> meta;
    // Asked before each cloud; true ends the import with DatasetError ("interrupted") and the
    // temporary directory is removed (SIGINT/SIGTERM in `maptune dataset import`).
    std::function<bool()> interrupted;
};

// Reads a TUM pose file for `clouds`; throws DatasetError naming the pose file when the
// counts differ.
std::vector<StampedPose> read_poses_for(const std::filesystem::path& tum, std::size_t clouds);

// Stanford `bun.conf`: "bmesh <file> tx ty tz q1 q2 q3 q4" lines. The pose of scan i in the
// common frame is R = quat(x=q1, y=q2, z=q3, w=q4)^T, t (convention checked numerically,
// see the data README). Files are resolved next to the conf.
ImportInput read_bunny_conf(const std::filesystem::path& conf);
// Options that fit the bunny's scale (0.15 m object, 0.5 mm scanner spacing).
ImportOptions bunny_options();

// Writes the dataset atomically; returns its id.
std::string import_dataset(const ImportInput& input, const ImportOptions& options,
                           const std::filesystem::path& out);

}  // namespace maptune::dataset
