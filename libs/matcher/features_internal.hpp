#pragma once
// Internal to libs/matcher: the PCL-backed ICP cloud shared by features.cpp and icp.cpp.

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include "matcher/features.hpp"

namespace maptune::matcher {

struct IcpCloud {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud;
    pcl::search::KdTree<pcl::PointXYZ>::Ptr tree;  // built once; ICP reuses it as target tree
};

}  // namespace maptune::matcher
