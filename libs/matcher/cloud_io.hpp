#pragma once
// Small readers for real scans such as tests/data (PLY/PCD via libs/dataset, CSV, bun.conf,
// 4x4 text matrices), so tests and benches need no PCL I/O. Errors: read_xyz throws for PLY/PCD;
// the others give an empty result / false.

#include <Eigen/Geometry>
#include <map>
#include <string>
#include <vector>

#include "dataset/submap.hpp"

namespace maptune::matcher::io {

// First three numeric columns of a CSV or whitespace-separated file; a header line is skipped.
std::vector<Eigen::Vector3f> read_csv_xyz(const std::string& path);

// By extension: .ply and .pcd as dataset::read_points reads them (throws dataset::DatasetError
// naming the file and the problem; points (0,0,0) are kept), anything else as CSV.
std::vector<Eigen::Vector3f> read_xyz(const std::string& path);

// Both scans of a pair by read_xyz; false with a message naming the file if either fails or
// holds no points (for command-line tools).
bool read_scan_pair(const std::string& target, const std::string& source,
                    std::vector<Eigen::Vector3f>& a, std::vector<Eigen::Vector3f>& b,
                    std::string& error);

// bun.conf: scan file name -> pose W_i of the scan in the common frame
// (R_i = quat(q1..q4 as x,y,z,w)^T, p_common = R_i p_scan + t_i; see the data README).
std::map<std::string, Eigen::Isometry3d> read_bunny_conf(const std::string& path);

// 4x4 whitespace-separated matrix; false if unreadable.
bool read_matrix4(const std::string& path, Eigen::Matrix4d& out);

// libpointmatcher carCloudList.csv: row index -> 4x4 pose (row-major gT00..gT33).
std::vector<Eigen::Matrix4d> read_car_cloud_list(const std::string& path);

// A submap without obstacles or octree (keypoints fall back to the cloud), grey colour.
dataset::Submap make_submap(const std::string& id, const std::vector<Eigen::Vector3f>& points,
                            bool drop_origin_points = true);

}  // namespace maptune::matcher::io
