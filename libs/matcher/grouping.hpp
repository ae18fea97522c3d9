#pragma once
// Hough3D grouping with the collinearity check (SPEC §3 step 8) and the seeded RANSAC rigid
// transform (step 9). Pure Eigen: deterministic given the seed, interruptible by a deadline.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "matcher/descriptor_matching.hpp"
#include "matcher/features.hpp"

namespace maptune::matcher {

struct HoughGroups {
    // Groups (indices into the correspondence list), largest first; ties by bin key.
    std::vector<std::vector<int>> groups;
    int largest_bin = 0;  // votes in the fullest bin, whether or not it reached n_tf (diagnostics)
};

// Votes as PCL's Hough3DGrouping without interpolation: b is the model, a the scene. Each
// correspondence (a_i, b_j) votes for the position of b's keypoint centroid in a's frame,
// a_i + R_a_i^T R_b_j (c_b - b_j), with R the LRF (rows = axes). Bins of edge v_tf with at
// least n_tf votes are groups.
HoughGroups hough_groups(const SubmapFeatures& a, const SubmapFeatures& b,
                         const std::vector<Correspondence>& corrs, double v_tf, int n_tf);

// RANSAC line fit: true if at least inlier_fraction of the points lie within threshold_m of
// one line through two of them (or if fewer than 3 distinct points).
bool is_collinear(const std::vector<Eigen::Vector3f>& points, double threshold_m,
                  double inlier_fraction, int iterations, std::uint64_t seed);

struct RigidRansacResult {
    bool ok = false;
    Eigen::Matrix4f T_a_b = Eigen::Matrix4f::Identity();
    std::vector<int> inliers;  // indices into the given correspondences
    bool timed_out = false;
};

// Rigid transform a <- b from correspondences (3-point samples, Umeyama without scale),
// refitted on the inliers of the best sample.
RigidRansacResult ransac_rigid(const Eigen::Matrix3Xf& points_a, const Eigen::Matrix3Xf& points_b,
                               double inlier_threshold_m, int iterations, std::uint64_t seed,
                               const Deadline& deadline = {});

}  // namespace maptune::matcher
