#pragma once
// File formats of a dataset: binary PCD (XYZRGB / XYZ), PLY and PCD import, TUM trajectories.
// Every failure throws DatasetError naming the file and the problem.

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "dataset/submap.hpp"

namespace maptune::dataset {

// Bad input (missing, truncated or inconsistent files). what() = "<file>: <problem>".
class DatasetError : public std::runtime_error {
public:
    DatasetError(const std::filesystem::path& file, const std::string& problem)
        : std::runtime_error(file.string() + ": " + problem), file_(file.string()) {}
    const std::string& file() const { return file_; }

private:
    std::string file_;
};

struct StampedPose {
    double timestamp = 0;  // seconds
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
};

// TUM: one line "timestamp tx ty tz qx qy qz qw"; '#' comments and blank lines ignored.
std::vector<StampedPose> read_tum(const std::filesystem::path& file);
std::string format_tum(const std::vector<StampedPose>& poses);

// Binary PCD v0.7 (FIELDS x y z rgb, rgb packed as in PCL's PointXYZRGB). Byte-stable.
std::string format_pcd_xyzrgb(const std::vector<ColoredPoint>& cloud);
std::string format_pcd_xyz(const std::vector<Eigen::Vector3f>& points);

struct ReadOptions {
    bool drop_nan = false;  // otherwise a non-finite coordinate is an error
};
// Reads PCD (ascii or binary; x y z required, rgb/rgba optional) or PLY (ascii or
// binary_little_endian; vertex x y z, red green blue optional), chosen by extension.
// Points without colour get grey (128). Throws DatasetError on any problem.
std::vector<ColoredPoint> read_cloud(const std::filesystem::path& file,
                                     const ReadOptions& options = {});
std::vector<Eigen::Vector3f> read_points(const std::filesystem::path& file,
                                         const ReadOptions& options = {});

std::string read_file(const std::filesystem::path& file);
// Writes then renames, so a crash never leaves a half-written file under the final name.
void write_file(const std::filesystem::path& file, const std::string& bytes);

// FNV-1a 64-bit, hex; used for the dataset content id (identification, not security).
std::uint64_t fnv1a(const std::string& bytes, std::uint64_t h = 1469598103934665603ull);
std::string hex64(std::uint64_t v);

}  // namespace maptune::dataset
