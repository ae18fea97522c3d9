#pragma once
// A second real matcher (issue 13): FPFH features + RANSAC + GICP, the pipeline many LiDAR
// robots use (as in Open3D's global registration), with PCL. Its own design space lives in
// configs/spaces/fpfh_gicp.yaml; plugins/fpfh_worker/main.cpp serves it through the worker
// SDK. This header has no PCL type: PCL stays in fpfh_matcher.cpp.
//
// Per cloud: voxel grid (voxel_m) -> normals within normal_scale voxels -> FPFH within
// feature_scale voxels. Per pair (A target, B source): every B point's n_corr nearest A
// histograms are candidate correspondences; RANSAC draws three, rejects triangles whose edge
// lengths differ by more than `similarity` allows, fits a rigid transform and counts
// correspondences within inlier_scale voxels; GICP refines the best on the downsampled clouds
// (correspondences within gicp_scale voxels); the pair is a match iff at least min_overlap of
// B's points then lie within inlier_scale voxels of A.
//
// Radii are in voxels, as FPFH is usually set: the work per point (neighbours within a radius)
// stays bounded wherever the optimizer goes, and a set tuned on one robot's data carries over
// to another scale by changing voxel_m alone.

#include <Eigen/Geometry>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace maptune::fpfh {

struct Params {
    double voxel_m = 0.1;
    double normal_scale = 2.5;   // normal radius / voxel_m
    double feature_scale = 5.0;  // FPFH radius / voxel_m
    int n_corr = 1;
    double similarity = 0.9;
    double inlier_scale = 1.5;   // RANSAC inlier (and overlap) distance / voxel_m
    double gicp_scale = 2.0;     // GICP correspondence distance / voxel_m
    double min_overlap = 0.3;

    double normal_radius_m() const { return normal_scale * voxel_m; }
    double feature_radius_m() const { return feature_scale * voxel_m; }
    double inlier_m() const { return inlier_scale * voxel_m; }
    double gicp_max_dist_m() const { return gicp_scale * voxel_m; }
};

// The parameter names of the design space, in Params' order.
const std::vector<std::string>& param_names();

// From a task's parameter map; throws std::invalid_argument naming a missing or invalid key.
Params params_from(const std::map<std::string, double>& values);

// Fixed settings: part of the matcher's version (results change with them).
struct Settings {
    int ransac_max_draws = 100000;  // triangles drawn at most (adaptive stop at 99.9 %)
    int gicp_iterations = 30;
    // Correspondence search + RANSAC of one pair: past it the pair is a timeout, not a hang
    // (many candidates per point and a loose pre-rejection make every draw count all of them).
    double pair_time_limit_s = 20;
};

// One cloud after voxel grid, normals and FPFH (opaque: PCL types inside).
struct Prepared;

struct PrepareResult {
    std::shared_ptr<const Prepared> cloud;  // nullptr: `reason` says why
    std::string reason;
    int points = 0;     // after the voxel grid
    double seconds = 0;
};

PrepareResult prepare(const std::vector<Eigen::Vector3f>& points, const Params& params);

struct PairOutcome {
    bool matched = false;
    bool timed_out = false;  // pair_time_limit_s passed: `reason` says where
    Eigen::Matrix4d T_a_b = Eigen::Matrix4d::Identity();  // B's points into A's frame
    int correspondences = 0;
    int ransac_inliers = 0;
    double overlap = 0;  // share of B's points within ransac_inlier_m of A after GICP
    std::string reason;  // why not matched
    double seconds = 0;
};

PairOutcome register_pair(const Prepared& a, const Prepared& b, const Params& params,
                          const Settings& settings, std::uint64_t seed);

}  // namespace maptune::fpfh
