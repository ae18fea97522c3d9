#pragma once
// In-memory submap: the contract between the dataset library (which produces and loads
// submaps) and the matcher (which consumes them). Poses are T_<to>_<from>.

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace octomap {
class OcTree;
}

namespace maptune::dataset {

struct ColoredPoint {
    float x = 0, y = 0, z = 0;  // metres, submap frame
    std::uint8_t r = 0, g = 0, b = 0;
};

struct Submap {
    std::string id;                        // unique within the dataset, e.g. "run03/submap012"
    std::vector<ColoredPoint> cloud;       // voxel-filtered, submap frame
    std::vector<Eigen::Vector3f> obstacles;  // keypoint candidates (SPEC §3 step 3), submap frame
    std::shared_ptr<const octomap::OcTree> octree;  // free/occupied/unknown; may be null
    // FNV-1a 64 over the bytes of the cloud, obstacle and OctoMap files it was loaded from
    // (Dataset::load_submap); 0 for a submap built in memory. Caches key on it: a submap
    // whose files changed under the same id never gets the features of the old one.
    std::uint64_t content_hash = 0;
    Eigen::Isometry3d T_world_submap_gt = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_world_submap_odom = Eigen::Isometry3d::Identity();
};

}  // namespace maptune::dataset
