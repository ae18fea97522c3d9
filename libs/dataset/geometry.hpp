#pragma once
// Point-cloud helpers shared by the simulator and the importer: voxel filter, obstacle
// detectors, OctoMap construction, overlap ratio and submap size.

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dataset/submap.hpp"

namespace octomap {
class OcTree;
}

namespace maptune::dataset {

// Voxel key of a point for a leaf size; packs three 21-bit signed indices.
std::uint64_t voxel_key(const Eigen::Vector3f& p, float leaf);

// Centroid (position and colour) per occupied voxel, ordered by voxel key (deterministic).
std::vector<ColoredPoint> voxel_filter(const std::vector<ColoredPoint>& cloud, float leaf);
std::vector<Eigen::Vector3f> voxel_filter(const std::vector<Eigen::Vector3f>& points, float leaf);

// Obstacles for a gravity-aligned cloud (z up), as a ground robot sees them.
struct HeightObstacleSettings {
    float cell = 0.1f;         // grid cell [m]
    float step = 0.12f;        // height step that a wheel cannot climb [m]
    float max_slope_deg = 30;  // steeper local slope is an obstacle
    float negative_drop = 0.2f;  // a cell next to a gap, beyond which the ground lies this much lower [m]
    // Only points up to this height above the lowest neighbouring ground are reported (<= 0:
    // no limit). A wall is one obstacle for navigation; its upper metres add thousands of
    // look-alike points and no information about where the obstacle is.
    float max_height = 0.0f;
    // Report one obstacle point per (x, y) cell of this size, the highest (> 0; 0: every
    // obstacle point). A grid-map obstacle detector, like the rover's, sees the elevation map:
    // the top surface of a rock and the top edge of a wall strip, not the wall's whole face —
    // whose flat, look-alike points would otherwise make most of the keypoints.
    float top_surface_cell = 0.0f;
};
std::vector<Eigen::Vector3f> detect_obstacles_height(const std::vector<ColoredPoint>& cloud,
                                                     const HeightObstacleSettings& s = {});

// Obstacles without a known gravity direction: points of high surface variation
// lambda0 / (lambda0 + lambda1 + lambda2) of the neighbours within `radius`.
struct CurvatureObstacleSettings {
    float radius = 0.15f;          // neighbourhood radius [m]
    float min_variation = 0.06f;   // 0 = plane, 1/3 = isotropic
    int min_neighbours = 8;
};
std::vector<Eigen::Vector3f> detect_obstacles_curvature(const std::vector<ColoredPoint>& cloud,
                                                        const CurvatureObstacleSettings& s = {});

// OctoMap of one cloud seen from `origin` (all in the same frame): free along rays,
// occupied at end points. `max_range` <= 0 means unlimited.
std::shared_ptr<octomap::OcTree> build_octree(const std::vector<ColoredPoint>& cloud,
                                              const Eigen::Vector3f& origin, double resolution,
                                              double max_range = -1);

// Standard OctoMap binary (.bt) bytes, written and read without the library's debug
// chatter on stderr. from_bt throws DatasetError naming `file` when bytes are bad.
std::string octree_to_bt(const octomap::OcTree& tree);
std::shared_ptr<octomap::OcTree> octree_from_bt(const std::string& bytes, const std::string& file);

// Distance from the submap origin to its farthest point (SPEC §2 `d`).
double submap_size(const std::vector<ColoredPoint>& cloud);

// Overlap of two clouds already in a common frame, as voxel sets of leaf `leaf`:
// |A ∩ B| / min(|A|, |B|). Returns 0 when either is empty.
double overlap_ratio(const std::vector<std::uint64_t>& sorted_keys_a,
                     const std::vector<std::uint64_t>& sorted_keys_b);
std::vector<std::uint64_t> world_voxel_keys(const std::vector<ColoredPoint>& cloud,
                                            const Eigen::Isometry3d& T_world_cloud, float leaf);

}  // namespace maptune::dataset
