// PCL translation unit 2 of 2: ICP refinement.
#include "matcher/icp.hpp"

#include <pcl/registration/icp.h>

#include "matcher/features_internal.hpp"

namespace maptune::matcher {

IcpResult refine_icp(const SubmapFeatures& a, const SubmapFeatures& b,
                     const Eigen::Matrix4f& T_a_b_init, double max_correspondence_m,
                     int max_iterations) {
    IcpResult result;
    result.T_a_b = T_a_b_init;
    if (!a.icp_cloud || !b.icp_cloud || a.icp_cloud->cloud->size() < 3 ||
        b.icp_cloud->cloud->size() < 3 || max_iterations <= 0 || !(max_correspondence_m > 0))
        return result;
    pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
    icp.setInputSource(b.icp_cloud->cloud);
    icp.setInputTarget(a.icp_cloud->cloud);
    // The target tree was built with the features; do not rebuild it per pair.
    icp.setSearchMethodTarget(a.icp_cloud->tree, true);
    icp.setMaxCorrespondenceDistance(max_correspondence_m);
    icp.setMaximumIterations(max_iterations);
    // Stop once an iteration moves < ~1 mm / ~0.03 deg: 1e-10 ran every pair to the
    // iteration cap for sub-micrometre changes, far below the error scale p cares about.
    icp.setTransformationEpsilon(1e-6);
    icp.setTransformationRotationEpsilon(1.0 - 1e-7);
    icp.setEuclideanFitnessEpsilon(1e-8);
    pcl::PointCloud<pcl::PointXYZ> aligned;
    icp.align(aligned, T_a_b_init);
    const Eigen::Matrix4f T = icp.getFinalTransformation();
    if (!T.allFinite()) return result;
    result.ok = true;
    result.converged = icp.hasConverged();
    result.T_a_b = T;
    result.fitness = icp.getFitnessScore(max_correspondence_m * max_correspondence_m);
    // Overlap after alignment, for the optional plausibility check of the match decision.
    const float max_d2 = static_cast<float>(max_correspondence_m * max_correspondence_m);
    pcl::Indices nn(1);
    std::vector<float> d2(1);
    std::size_t near = 0;
    for (const auto& p : aligned.points)
        if (a.icp_cloud->tree->nearestKSearch(p, 1, nn, d2) == 1 && d2[0] <= max_d2) ++near;
    result.inlier_fraction = aligned.empty() ? 0.0 : static_cast<double>(near) / aligned.size();
    return result;
}

}  // namespace maptune::matcher
