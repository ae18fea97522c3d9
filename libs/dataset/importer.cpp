#include "dataset/importer.hpp"

#include <octomap/OcTree.h>

#include <fstream>
#include <sstream>

#include "dataset/dataset.hpp"
#include "dataset/geometry.hpp"

namespace maptune::dataset {
namespace fs = std::filesystem;

std::vector<StampedPose> read_poses_for(const fs::path& tum, std::size_t clouds) {
    auto poses = read_tum(tum);
    if (poses.size() != clouds) {
        throw DatasetError(tum, "has " + std::to_string(poses.size()) + " poses but " +
                                    std::to_string(clouds) + " clouds were given (one pose per cloud, in order)");
    }
    return poses;
}

ImportInput read_bunny_conf(const fs::path& conf) {
    std::istringstream in(read_file(conf));
    ImportInput input;
    std::string line;
    int line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        std::istringstream ls(line);
        std::string key;
        if (!(ls >> key) || key != "bmesh") continue;  // the "camera" line is not a scan
        std::string file;
        double t[3], q[4];
        if (!(ls >> file >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3])) {
            throw DatasetError(conf, "line " + std::to_string(line_no) +
                                         ": expected 'bmesh <file> tx ty tz q1 q2 q3 q4'");
        }
        const Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
        if (std::abs(quat.norm() - 1) > 1e-3) {
            throw DatasetError(conf, "line " + std::to_string(line_no) + ": quaternion not unit length");
        }
        StampedPose p;
        p.timestamp = static_cast<double>(input.poses.size());
        p.T = Eigen::Isometry3d::Identity();
        p.T.linear() = quat.normalized().toRotationMatrix().transpose();
        p.T.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
        input.poses.push_back(p);
        input.clouds.push_back(conf.parent_path() / file);
    }
    if (input.clouds.empty()) throw DatasetError(conf, "no 'bmesh' lines (not a bun.conf?)");
    return input;
}

ImportOptions bunny_options() {
    ImportOptions o;
    o.name = "stanford-bunny";
    o.voxel_m = 0.002;
    o.octomap_resolution_m = 0.004;
    // The Cyberware scanner looks down the scan frame's -z axis from about +z; 0.25 m keeps
    // the rays short. Only the free space in front of the surface depends on this.
    o.sensor_origin = Eigen::Vector3f(0, 0, 0.25f);
    o.obstacle_method = "curvature";
    o.curvature_radius_m = 0.006;
    o.curvature_threshold = 0.05;
    return o;
}

std::string import_dataset(const ImportInput& in, const ImportOptions& o, const fs::path& out) {
    if (in.clouds.empty()) throw DatasetError(out, "no input clouds given");
    if (in.poses.size() != in.clouds.size()) {
        throw DatasetError(out, std::to_string(in.poses.size()) + " poses for " +
                                    std::to_string(in.clouds.size()) + " clouds");
    }
    if (!in.odometry.empty() && in.odometry.size() != in.clouds.size()) {
        throw DatasetError(out, "odometry has " + std::to_string(in.odometry.size()) + " poses for " +
                                    std::to_string(in.clouds.size()) + " clouds");
    }
    if (!in.obstacles.empty() && in.obstacles.size() != in.clouds.size()) {
        throw DatasetError(out, "obstacle files: " + std::to_string(in.obstacles.size()) + " for " +
                                    std::to_string(in.clouds.size()) + " clouds");
    }
    if (!in.octomaps.empty() && in.octomaps.size() != in.clouds.size()) {
        throw DatasetError(out, "OctoMap files: " + std::to_string(in.octomaps.size()) + " for " +
                                    std::to_string(in.clouds.size()) + " clouds");
    }
    if (o.obstacle_method != "curvature" && o.obstacle_method != "height") {
        throw std::invalid_argument("unknown obstacle method '" + o.obstacle_method + "' (curvature|height)");
    }
    // Validate every input before writing anything.
    for (const auto& f : in.clouds) {
        if (!fs::exists(f)) throw DatasetError(f, "missing cloud file");
    }
    DatasetWriter writer(out, o.name, "import", o.voxel_m, 4 * o.voxel_m, o.overwrite);
    for (const auto& [k, v] : o.meta) writer.set_meta(k, v);
    writer.set_meta("obstacles", in.obstacles.empty() ? "derived:" + o.obstacle_method : "given");
    writer.set_meta("octomap", in.octomaps.empty() ? "derived:rays-from-sensor-origin" : "given");
    writer.set_meta("odometry", in.odometry.empty() ? "copy-of-gt" : "given");
    RunWriter rw = writer.run(0);
    ReadOptions ro;
    ro.drop_nan = o.drop_nan;
    for (std::size_t i = 0; i < in.clouds.size(); ++i) {
        if (o.interrupted && o.interrupted()) throw DatasetError(out, "interrupted: nothing written");
        Submap s;
        s.cloud = voxel_filter(read_cloud(in.clouds[i], ro), static_cast<float>(o.voxel_m));
        if (!in.obstacles.empty()) {
            s.obstacles = read_points(in.obstacles[i], ro);
        } else if (o.obstacle_method == "height") {
            HeightObstacleSettings hs;
            hs.cell = static_cast<float>(std::max(2.5 * o.voxel_m, 0.05));
            s.obstacles = detect_obstacles_height(s.cloud, hs);
        } else {
            CurvatureObstacleSettings cs;
            cs.radius = static_cast<float>(o.curvature_radius_m);
            cs.min_variation = static_cast<float>(o.curvature_threshold);
            s.obstacles = detect_obstacles_curvature(s.cloud, cs);
        }
        if (!in.octomaps.empty()) {
            s.octree = octree_from_bt(read_file(in.octomaps[i]), in.octomaps[i].string());
        } else {
            s.octree = build_octree(s.cloud, o.sensor_origin, o.octomap_resolution_m, o.max_range_m);
        }
        s.T_world_submap_gt = in.poses[i].T;
        s.T_world_submap_odom = in.odometry.empty() ? in.poses[i].T : in.odometry[i].T;
        rw.add_submap(s, in.poses[i].timestamp);
    }
    rw.finish();
    return writer.finish();
}

}  // namespace maptune::dataset
