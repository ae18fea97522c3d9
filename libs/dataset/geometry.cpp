#include "dataset/geometry.hpp"

#include <octomap/OcTree.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include "dataset/io.hpp"

namespace maptune::dataset {

namespace {
constexpr std::int64_t kBias = 1 << 20;
constexpr std::uint64_t kMask = (1u << 21) - 1;

std::int64_t cell_index(float v, float leaf) {
    return static_cast<std::int64_t>(std::floor(v / leaf));
}
}  // namespace

std::uint64_t voxel_key(const Eigen::Vector3f& p, float leaf) {
    const auto ix = static_cast<std::uint64_t>(cell_index(p.x(), leaf) + kBias) & kMask;
    const auto iy = static_cast<std::uint64_t>(cell_index(p.y(), leaf) + kBias) & kMask;
    const auto iz = static_cast<std::uint64_t>(cell_index(p.z(), leaf) + kBias) & kMask;
    return (ix << 42) | (iy << 21) | iz;
}

std::vector<ColoredPoint> voxel_filter(const std::vector<ColoredPoint>& cloud, float leaf) {
    struct Acc {
        double x = 0, y = 0, z = 0, r = 0, g = 0, b = 0;
        int n = 0;
    };
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed;
    keyed.reserve(cloud.size());
    for (std::uint32_t i = 0; i < cloud.size(); ++i) {
        const auto& p = cloud[i];
        keyed.emplace_back(voxel_key({p.x, p.y, p.z}, leaf), i);
    }
    std::sort(keyed.begin(), keyed.end());  // stable order => byte-identical output
    std::vector<ColoredPoint> out;
    for (std::size_t i = 0; i < keyed.size();) {
        Acc a;
        std::size_t j = i;
        for (; j < keyed.size() && keyed[j].first == keyed[i].first; ++j) {
            const auto& p = cloud[keyed[j].second];
            a.x += p.x; a.y += p.y; a.z += p.z;
            a.r += p.r; a.g += p.g; a.b += p.b;
            ++a.n;
        }
        ColoredPoint q;
        q.x = static_cast<float>(a.x / a.n);
        q.y = static_cast<float>(a.y / a.n);
        q.z = static_cast<float>(a.z / a.n);
        q.r = static_cast<std::uint8_t>(std::lround(a.r / a.n));
        q.g = static_cast<std::uint8_t>(std::lround(a.g / a.n));
        q.b = static_cast<std::uint8_t>(std::lround(a.b / a.n));
        out.push_back(q);
        i = j;
    }
    return out;
}

std::vector<Eigen::Vector3f> voxel_filter(const std::vector<Eigen::Vector3f>& points, float leaf) {
    std::vector<ColoredPoint> c;
    c.reserve(points.size());
    for (const auto& p : points) {
        ColoredPoint q;
        q.x = p.x(); q.y = p.y(); q.z = p.z();
        c.push_back(q);
    }
    std::vector<Eigen::Vector3f> out;
    for (const auto& q : voxel_filter(c, leaf)) out.emplace_back(q.x, q.y, q.z);
    return out;
}

std::vector<Eigen::Vector3f> detect_obstacles_height(const std::vector<ColoredPoint>& cloud,
                                                     const HeightObstacleSettings& s) {
    struct Cell {
        float zmin = 1e9f, zmax = -1e9f;
    };
    auto key2 = [](std::int64_t ix, std::int64_t iy) {
        return (static_cast<std::uint64_t>(ix + kBias) << 32) | static_cast<std::uint64_t>(iy + kBias);
    };
    std::unordered_map<std::uint64_t, Cell> grid;
    grid.reserve(cloud.size());
    for (const auto& p : cloud) {
        Cell& c = grid[key2(cell_index(p.x, s.cell), cell_index(p.y, s.cell))];
        c.zmin = std::min(c.zmin, p.z);
        c.zmax = std::max(c.zmax, p.z);
    }
    const float slope = std::tan(s.max_slope_deg * static_cast<float>(M_PI) / 180.f);
    std::vector<Eigen::Vector3f> out;
    for (const auto& p : cloud) {
        const std::int64_t ix = cell_index(p.x, s.cell), iy = cell_index(p.y, s.cell);
        bool obstacle = false;
        float ground = p.z;
        // Step or steep slope: this point stands clearly above some neighbouring ground.
        for (int dx = -1; dx <= 1; ++dx) {
            for (int dy = -1; dy <= 1; ++dy) {
                auto it = grid.find(key2(ix + dx, iy + dy));
                if (it == grid.end()) continue;
                ground = std::min(ground, it->second.zmin);
                const float dist = s.cell * std::sqrt(float(dx * dx + dy * dy)) + s.cell;
                const float rise = p.z - it->second.zmin;
                if (rise > s.step || rise > slope * dist + 0.5f * s.cell * slope) obstacle = true;
            }
        }
        if (obstacle && s.max_height > 0 && p.z - ground > s.max_height) continue;
        // Negative edge (crater rim, drop-off): a gap right next to the point, and beyond
        // it ground that lies much lower (the far wall of the hole).
        if (!obstacle) {
            static const int dirs[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1},
                                           {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};
            for (const auto& d : dirs) {
                if (grid.count(key2(ix + d[0], iy + d[1]))) continue;
                for (int k = 2; k <= 5; ++k) {
                    auto it = grid.find(key2(ix + k * d[0], iy + k * d[1]));
                    if (it == grid.end()) continue;
                    if (it->second.zmax < p.z - s.negative_drop) obstacle = true;
                    break;
                }
                if (obstacle) break;
            }
        }
        if (obstacle) out.emplace_back(p.x, p.y, p.z);
    }
    if (s.top_surface_cell <= 0) return out;
    // Highest obstacle point per cell; output in order of first appearance (deterministic).
    std::unordered_map<std::uint64_t, std::size_t> top;
    std::vector<Eigen::Vector3f> tops;
    for (const auto& p : out) {
        const auto k = key2(cell_index(p.x(), s.top_surface_cell), cell_index(p.y(), s.top_surface_cell));
        const auto [it, fresh] = top.emplace(k, tops.size());
        if (fresh)
            tops.push_back(p);
        else if (p.z() > tops[it->second].z())
            tops[it->second] = p;
    }
    return tops;
}

std::vector<Eigen::Vector3f> detect_obstacles_curvature(const std::vector<ColoredPoint>& cloud,
                                                        const CurvatureObstacleSettings& s) {
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
    for (std::uint32_t i = 0; i < cloud.size(); ++i) {
        const auto& p = cloud[i];
        grid[voxel_key({p.x, p.y, p.z}, s.radius)].push_back(i);
    }
    const float r2 = s.radius * s.radius;
    std::vector<Eigen::Vector3f> out;
    for (const auto& p : cloud) {
        const Eigen::Vector3f c(p.x, p.y, p.z);
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        int n = 0;
        const auto ix = cell_index(p.x, s.radius), iy = cell_index(p.y, s.radius),
                   iz = cell_index(p.z, s.radius);
        for (int dx = -1; dx <= 1; ++dx) {
            for (int dy = -1; dy <= 1; ++dy) {
                for (int dz = -1; dz <= 1; ++dz) {
                    const Eigen::Vector3f q((ix + dx + 0.5f) * s.radius, (iy + dy + 0.5f) * s.radius,
                                            (iz + dz + 0.5f) * s.radius);
                    auto it = grid.find(voxel_key(q, s.radius));
                    if (it == grid.end()) continue;
                    for (auto j : it->second) {
                        const Eigen::Vector3f o(cloud[j].x, cloud[j].y, cloud[j].z);
                        if ((o - c).squaredNorm() > r2) continue;
                        const Eigen::Vector3d od = o.cast<double>();
                        mean += od;
                        cov += od * od.transpose();
                        ++n;
                    }
                }
            }
        }
        if (n < s.min_neighbours) continue;
        mean /= n;
        cov = cov / n - mean * mean.transpose();
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov, Eigen::EigenvaluesOnly);
        const Eigen::Vector3d ev = es.eigenvalues().cwiseMax(0.0);
        const double sum = ev.sum();
        if (sum > 0 && ev(0) / sum > s.min_variation) out.push_back(c);
    }
    return out;
}

std::shared_ptr<octomap::OcTree> build_octree(const std::vector<ColoredPoint>& cloud,
                                              const Eigen::Vector3f& origin, double resolution,
                                              double max_range) {
    auto tree = std::make_shared<octomap::OcTree>(resolution);
    octomap::Pointcloud pc;
    pc.reserve(cloud.size());
    for (const auto& p : cloud) pc.push_back(p.x, p.y, p.z);
    tree->insertPointCloud(pc, octomap::point3d(origin.x(), origin.y(), origin.z()), max_range,
                           /*lazy_eval=*/false, /*discretize=*/true);
    tree->updateInnerOccupancy();
    tree->prune();
    return tree;
}

std::string octree_to_bt(const octomap::OcTree& tree) {
    std::ostringstream s;
    s << "# Octomap OcTree binary file\n# (feel free to add / change comments, but leave the first "
         "line as it is!)\n#\n";
    s << "id " << tree.getTreeType() << "\n";
    s << "size " << tree.size() << "\n";
    s << "res " << tree.getResolution() << "\n";
    s << "data\n";
    // Qualified call: the header template (compiled here) instead of the library's copy.
    tree.octomap::OccupancyOcTreeBase<octomap::OcTreeNode>::writeBinaryData(s);
    return s.str();
}

namespace {

// OctoMap reads its binary data recursively, one stack frame per level: a crafted chain of
// inner nodes deeper than the tree's 16 levels overflowed the stack. Walks the same layout
// iteratively first (per node two bytes, two bits per child, 11 = inner child whose subtree
// follows in child order) and refuses what the reader must not see.
void check_bt_data(const std::string& bytes, std::size_t pos, const std::string& file) {
    constexpr std::size_t kLeafDepth = 16;  // octomap::OcTree's tree_depth
    std::vector<int> pending;  // per open level: inner children still to read
    for (;;) {
        const std::size_t depth = pending.size();
        if (pos + 2 > bytes.size()) throw DatasetError(file, "truncated OctoMap data");
        int inner = 0;
        for (int b = 0; b < 2; ++b) {
            const auto bits = static_cast<unsigned char>(bytes[pos + static_cast<std::size_t>(b)]);
            for (int i = 0; i < 4; ++i) inner += ((bits >> (2 * i)) & 3u) == 3u;
        }
        pos += 2;
        if (inner > 0 && depth + 1 >= kLeafDepth) {
            throw DatasetError(file, "OctoMap data deeper than " + std::to_string(kLeafDepth) + " levels");
        }
        pending.push_back(inner);
        while (!pending.empty() && pending.back() == 0) pending.pop_back();
        if (pending.empty()) return;
        --pending.back();
    }
}

}  // namespace

std::shared_ptr<octomap::OcTree> octree_from_bt(const std::string& bytes, const std::string& file) {
    std::istringstream in(bytes);
    std::string line;
    if (!std::getline(in, line) || line.rfind("# Octomap OcTree binary file", 0) != 0) {
        throw DatasetError(file, "not an OctoMap binary file (.bt)");
    }
    std::string id;
    double res = 0;
    std::size_t size = 0;
    bool data = false;
    while (std::getline(in, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty() || line[0] == '#') continue;
        std::istringstream ls(line);
        std::string key;
        ls >> key;
        if (key == "id") ls >> id;
        else if (key == "size") ls >> size;
        else if (key == "res") ls >> res;
        else if (key == "data") { data = true; break; }
    }
    if (!data) throw DatasetError(file, "truncated OctoMap header (no 'data' line)");
    if (id != "OcTree") throw DatasetError(file, "OctoMap tree type '" + id + "' is not OcTree");
    if (!(res > 0)) throw DatasetError(file, "OctoMap resolution missing or not positive");
    auto tree = std::make_shared<octomap::OcTree>(res);
    if (size > 0) {
        const auto at = in.tellg();
        if (at < 0) throw DatasetError(file, "truncated OctoMap data");
        check_bt_data(bytes, static_cast<std::size_t>(at), file);
        tree->octomap::OccupancyOcTreeBase<octomap::OcTreeNode>::readBinaryData(in);
        if (!in || tree->size() != size) {
            throw DatasetError(file, "truncated OctoMap data: header announces " + std::to_string(size) +
                                         " nodes, read " + std::to_string(tree->size()));
        }
    }
    return tree;
}

double submap_size(const std::vector<ColoredPoint>& cloud) {
    double d2 = 0;
    for (const auto& p : cloud) {
        d2 = std::max(d2, double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z);
    }
    return std::sqrt(d2);
}

std::vector<std::uint64_t> world_voxel_keys(const std::vector<ColoredPoint>& cloud,
                                            const Eigen::Isometry3d& T_world_cloud, float leaf) {
    const Eigen::Isometry3f T = T_world_cloud.cast<float>();
    std::vector<std::uint64_t> keys;
    keys.reserve(cloud.size());
    for (const auto& p : cloud) keys.push_back(voxel_key(T * Eigen::Vector3f(p.x, p.y, p.z), leaf));
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    return keys;
}

double overlap_ratio(const std::vector<std::uint64_t>& a, const std::vector<std::uint64_t>& b) {
    if (a.empty() || b.empty()) return 0;
    std::size_t i = 0, j = 0, common = 0;
    while (i < a.size() && j < b.size()) {
        if (a[i] < b[j]) ++i;
        else if (b[j] < a[i]) ++j;
        else { ++common; ++i; ++j; }
    }
    return double(common) / double(std::min(a.size(), b.size()));
}

}  // namespace maptune::dataset
