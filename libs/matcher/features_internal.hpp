#pragma once
// Internal to libs/matcher: the PCL-backed ICP cloud shared by features.cpp and icp.cpp.

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include "matcher/features.hpp"

namespace maptune::matcher {

// Normals are set for point-to-plane ICP and zero for point-to-point.
using IcpPoint = pcl::PointNormal;

struct IcpCloud {
    pcl::PointCloud<IcpPoint>::Ptr cloud;
    pcl::search::KdTree<IcpPoint>::Ptr tree;  // built once; ICP reuses it as target tree
    pcl::PointCloud<IcpPoint>::Ptr source;     // the subset used when this submap is the source
};

}  // namespace maptune::matcher
