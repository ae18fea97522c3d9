#include "matcher/cloud_io.hpp"

#include <cstring>
#include <fstream>
#include <sstream>

namespace maptune::matcher::io {
namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() &&
           s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::size_t type_size(const std::string& t) {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" ||
        t == "float32")
        return 4;
    if (t == "double" || t == "float64") return 8;
    return 0;
}

double read_binary(const char* p, const std::string& t) {
    if (t == "float" || t == "float32") {
        float v;
        std::memcpy(&v, p, 4);
        return v;
    }
    if (t == "double" || t == "float64") {
        double v;
        std::memcpy(&v, p, 8);
        return v;
    }
    return 0.0;  // only float coordinates are supported; others read as 0
}

}  // namespace

std::vector<Eigen::Vector3f> read_ply_xyz(const std::string& path) {
    std::vector<Eigen::Vector3f> out;
    std::ifstream in(path, std::ios::binary);
    if (!in) return out;
    std::string line;
    if (!std::getline(in, line) || line.rfind("ply", 0) != 0) return out;
    bool binary = false;
    std::size_t vertex_count = 0;
    bool in_vertex = false, vertex_first = false, seen_element = false;
    std::vector<std::pair<std::string, std::string>> props;  // name, type
    while (std::getline(in, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::istringstream ls(line);
        std::string word;
        ls >> word;
        if (word == "format") {
            std::string fmt;
            ls >> fmt;
            if (fmt == "binary_big_endian") return out;
            binary = fmt == "binary_little_endian";
        } else if (word == "element") {
            std::string name;
            std::size_t count = 0;
            ls >> name >> count;
            in_vertex = name == "vertex";
            if (in_vertex) {
                vertex_count = count;
                vertex_first = !seen_element;
            }
            seen_element = true;
        } else if (word == "property" && in_vertex) {
            std::string type, name;
            ls >> type >> name;
            if (type == "list") return out;
            props.emplace_back(name, type);
        } else if (word == "end_header") {
            break;
        }
    }
    if (!vertex_first || vertex_count == 0) return out;
    int ix = -1, iy = -1, iz = -1;
    for (std::size_t i = 0; i < props.size(); ++i) {
        if (props[i].first == "x") ix = static_cast<int>(i);
        if (props[i].first == "y") iy = static_cast<int>(i);
        if (props[i].first == "z") iz = static_cast<int>(i);
    }
    if (ix < 0 || iy < 0 || iz < 0) return out;
    out.reserve(vertex_count);
    if (binary) {
        std::vector<std::size_t> offset(props.size());
        std::size_t stride = 0;
        for (std::size_t i = 0; i < props.size(); ++i) {
            offset[i] = stride;
            const std::size_t s = type_size(props[i].second);
            if (s == 0) return {};
            stride += s;
        }
        std::vector<char> buf(stride);
        for (std::size_t v = 0; v < vertex_count; ++v) {
            if (!in.read(buf.data(), static_cast<std::streamsize>(stride))) return {};
            out.emplace_back(
                static_cast<float>(read_binary(buf.data() + offset[ix], props[ix].second)),
                static_cast<float>(read_binary(buf.data() + offset[iy], props[iy].second)),
                static_cast<float>(read_binary(buf.data() + offset[iz], props[iz].second)));
        }
    } else {
        std::vector<double> vals(props.size());
        for (std::size_t v = 0; v < vertex_count && std::getline(in, line); ++v) {
            std::istringstream ls(line);
            for (auto& x : vals) ls >> x;
            if (!ls) return {};
            out.emplace_back(static_cast<float>(vals[ix]), static_cast<float>(vals[iy]),
                             static_cast<float>(vals[iz]));
        }
    }
    return out;
}

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
    return ends_with(path, ".ply") ? read_ply_xyz(path) : read_csv_xyz(path);
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
