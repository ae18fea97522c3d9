#pragma once
// ICP refinement on the cached full clouds (SPEC §3 step 9); implemented with PCL in icp.cpp.

#include <Eigen/Core>

#include "matcher/features.hpp"

namespace maptune::matcher {

struct IcpResult {
    bool ok = false;                                      // finite result
    Eigen::Matrix4f T_a_b = Eigen::Matrix4f::Identity();  // refined pose of b in a's frame
    double fitness = -1.0;                                // mean squared inlier distance [m^2]
    bool converged = false;
    double inlier_fraction = 0.0;  // source points within max_correspondence_m after ICP
};

// Aligns b's ICP cloud (source) to a's (target) starting from T_a_b_init; point-to-plane
// needs the clouds' normals (MatcherSettings::icp_point_to_plane when they were computed).
IcpResult refine_icp(const SubmapFeatures& a, const SubmapFeatures& b,
                     const Eigen::Matrix4f& T_a_b_init, double max_correspondence_m,
                     int max_iterations, bool point_to_plane);

}  // namespace maptune::matcher
