#include "matcher/cloud_io.hpp"

#include <exception>
#include <fstream>
#include <sstream>

#include "dataset/io.hpp"

namespace maptune::matcher::io {
namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() &&
           s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

std::vector<Eigen::Vector3f> read_csv_xyz(const std::string& path) {
    std::vector<Eigen::Vector3f> out;
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line)) {
        for (char& c : line)
            if (c == ',' || c == ';' || c == '\t') c = ' ';
        std::istringstream ls(line);
        double x, y, z;
        if (ls >> x >> y >> z) out.emplace_back(float(x), float(y), float(z));
    }
    return out;
}

std::vector<Eigen::Vector3f> read_xyz(const std::string& path) {
    // PLY and PCD through the dataset reader: one parser, and its errors name file and problem.
    if (ends_with(path, ".ply") || ends_with(path, ".pcd")) return dataset::read_points(path);
    return read_csv_xyz(path);
}

bool read_scan_pair(const std::string& target, const std::string& source,
                    std::vector<Eigen::Vector3f>& a, std::vector<Eigen::Vector3f>& b,
                    std::string& error) {
    try {
        a = read_xyz(target);
        b = read_xyz(source);
    } catch (const std::exception& e) {
        error = e.what();
        return false;
    }
    if (a.empty() || b.empty()) {
        error = "no points read from " + (a.empty() ? target : source);
        return false;
    }
    return true;
}

std::map<std::string, Eigen::Isometry3d> read_bunny_conf(const std::string& path) {
    std::map<std::string, Eigen::Isometry3d> out;
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream ls(line);
        std::string tag, file;
        double tx, ty, tz, q1, q2, q3, q4;
        if (!(ls >> tag) || tag != "bmesh") continue;
        if (!(ls >> file >> tx >> ty >> tz >> q1 >> q2 >> q3 >> q4)) continue;
        const Eigen::Quaterniond q(q4, q1, q2, q3);  // Eigen order (w, x, y, z)
        Eigen::Isometry3d W = Eigen::Isometry3d::Identity();
        W.linear() = q.normalized().toRotationMatrix().transpose();
        W.translation() = Eigen::Vector3d(tx, ty, tz);
        out[file] = W;
    }
    return out;
}

bool read_matrix4(const std::string& path, Eigen::Matrix4d& out) {
    std::ifstream in(path);
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
            if (!(in >> out(r, c))) return false;
    return true;
}

std::vector<Eigen::Matrix4d> read_car_cloud_list(const std::string& path) {
    std::vector<Eigen::Matrix4d> out;
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line)) {
        for (char& c : line)
            if (c == ',') c = ' ';
        std::istringstream ls(line);
        std::string name;
        ls >> name;
        Eigen::Matrix4d T;
        bool ok = true;
        for (int r = 0; r < 4 && ok; ++r)
            for (int c = 0; c < 4 && ok; ++c) ok = static_cast<bool>(ls >> T(r, c));
        if (ok) out.push_back(T);
    }
    return out;
}

dataset::Submap make_submap(const std::string& id, const std::vector<Eigen::Vector3f>& points,
                            bool drop_origin_points) {
    dataset::Submap s;
    s.id = id;
    s.cloud.reserve(points.size());
    for (const auto& p : points) {
        if (drop_origin_points && p.x() == 0.f && p.y() == 0.f && p.z() == 0.f) continue;
        dataset::ColoredPoint q;
        q.x = p.x(), q.y = p.y(), q.z = p.z();
        q.r = q.g = q.b = 128;
        s.cloud.push_back(q);
    }
    return s;
}

}  // namespace maptune::matcher::io
