// PCL translation unit 2 of 2: ICP refinement.
#include "matcher/icp.hpp"

#include <pcl/registration/icp.h>

#include <limits>

#include "matcher/features_internal.hpp"

namespace maptune::matcher {

IcpResult refine_icp(const SubmapFeatures& a, const SubmapFeatures& b,
                     const Eigen::Matrix4f& T_a_b_init, double max_correspondence_m,
                     int max_iterations, bool point_to_plane_enabled) {
    IcpResult result;
    result.T_a_b = T_a_b_init;
    if (!a.icp_cloud || !b.icp_cloud || a.icp_cloud->cloud->size() < 3 ||
        b.icp_cloud->source->size() < 3 || max_iterations <= 0 || !(max_correspondence_m > 0))
        return result;
    pcl::IterativeClosestPoint<IcpPoint, IcpPoint> point_to_point;
    pcl::IterativeClosestPointWithNormals<IcpPoint, IcpPoint> point_to_plane;
    pcl::IterativeClosestPoint<IcpPoint, IcpPoint>& icp =
        point_to_plane_enabled ? point_to_plane : point_to_point;
    icp.setInputSource(b.icp_cloud->source);
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
    pcl::PointCloud<IcpPoint> aligned;
    icp.align(aligned, T_a_b_init);
    const Eigen::Matrix4f T = icp.getFinalTransformation();
    if (!T.allFinite()) return result;
    result.ok = true;
    result.converged = icp.hasConverged();
    result.T_a_b = T;
    // Fitness (PCL's definition: mean squared distance of the source points within the
    // correspondence distance) and overlap, for the optional plausibility check, in one
    // nearest-neighbour pass instead of PCL's getFitnessScore plus a second pass.
    const float max_d2 = static_cast<float>(max_correspondence_m * max_correspondence_m);
    pcl::Indices nn(1);
    std::vector<float> d2(1);
    std::size_t near = 0;
    double sum_d2 = 0.0;
    for (const auto& p : aligned.points) {
        if (a.icp_cloud->tree->nearestKSearch(p, 1, nn, d2) == 1 && d2[0] <= max_d2) {
            ++near;
            sum_d2 += d2[0];
        }
    }
    result.fitness = near > 0 ? sum_d2 / static_cast<double>(near) : std::numeric_limits<double>::max();
    result.inlier_fraction = aligned.empty() ? 0.0 : static_cast<double>(near) / aligned.size();
    return result;
}

}  // namespace maptune::matcher
