// A matcher plug-in built on the worker SDK only (issue 13): odometry-seeded point-to-point
// ICP between two submaps, the registration many robots run between subsequent submaps. It
// includes maptune_sdk/worker.hpp and libs/dataset — no DDS header (ctest SdkPlugin.*).
//
//   maptune_icp_worker --space configs/spaces/icp_odometry.yaml --domain 42
#include <Eigen/Geometry>

#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "maptune_sdk/worker.hpp"

namespace {

using maptune::sdk::Outcome;
using maptune::sdk::PairResult;
using maptune::sdk::PairStatus;
using maptune::sdk::Task;
using Points = std::vector<Eigen::Vector3d>;

std::int64_t cell_key(const Eigen::Vector3d& p, double leaf) {
    const auto c = [&](double v) { return static_cast<std::int64_t>(std::floor(v / leaf)) & 0x1fffff; };
    return (c(p.x()) << 42) | (c(p.y()) << 21) | c(p.z());
}

// Centroid of each occupied voxel.
Points downsample(const std::vector<maptune::dataset::ColoredPoint>& cloud, double leaf) {
    std::unordered_map<std::int64_t, std::pair<Eigen::Vector3d, int>> cells;
    for (const auto& p : cloud) {
        const Eigen::Vector3d v(p.x, p.y, p.z);
        auto& c = cells[cell_key(v, leaf)];
        c.first += v;
        ++c.second;
    }
    Points out;
    out.reserve(cells.size());
    for (const auto& [key, c] : cells) out.push_back(c.first / c.second);
    return out;
}

// Nearest neighbour within `radius` by a hash grid of cell `radius`.
class Grid {
public:
    Grid(const Points& pts, double radius) : pts_(pts), r_(radius) {
        for (std::size_t i = 0; i < pts.size(); ++i) cells_[key(cell(pts[i]))].push_back(static_cast<int>(i));
    }
    int nearest(const Eigen::Vector3d& q, double* d2_out) const {
        const Eigen::Vector3i c = cell(q);
        int best = -1;
        double best_d2 = r_ * r_;
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz) {
                    const auto it = cells_.find(key(c + Eigen::Vector3i(dx, dy, dz)));
                    if (it == cells_.end()) continue;
                    for (int i : it->second) {
                        const double d2 = (pts_[static_cast<std::size_t>(i)] - q).squaredNorm();
                        if (d2 <= best_d2) {
                            best_d2 = d2;
                            best = i;
                        }
                    }
                }
        *d2_out = best_d2;
        return best;
    }

private:
    Eigen::Vector3i cell(const Eigen::Vector3d& p) const {
        return (p / r_).array().floor().cast<int>();
    }
    static std::int64_t key(const Eigen::Vector3i& c) {
        return ((static_cast<std::int64_t>(c.x()) & 0x1fffff) << 42) |
               ((static_cast<std::int64_t>(c.y()) & 0x1fffff) << 21) | (static_cast<std::int64_t>(c.z()) & 0x1fffff);
    }
    const Points& pts_;
    double r_;
    std::unordered_map<std::int64_t, std::vector<int>> cells_;
};

class IcpMatcher : public maptune::sdk::Matcher {
public:
    std::string id() const override { return "icp_odometry"; }
    std::string version() const override { return "1"; }

    Outcome run(const Task& task, maptune::sdk::Datasets& datasets) override {
        const double leaf = task.params.at("voxel_m"), max_dist = task.params.at("max_dist_m");
        const int iterations = static_cast<int>(task.params.at("iterations"));
        const double min_inliers = task.params.at("min_inliers");
        return maptune::sdk::run_pairs(task, datasets, [&](const maptune::dataset::Dataset& ds, const std::string& a_id,
                                                           const std::string& b_id, PairResult& r) {
            const auto a = ds.load_submap(a_id), b = ds.load_submap(b_id);
            match(downsample(a.cloud, leaf), downsample(b.cloud, leaf),
                  a.T_world_submap_odom.inverse() * b.T_world_submap_odom, max_dist, iterations, min_inliers, r);
        });
    }

private:
    static void match(const Points& a, const Points& b, Eigen::Isometry3d T, double max_dist, int iterations,
                      double min_inliers, PairResult& r) {
        if (a.size() < 3 || b.size() < 3) {
            r.reason = "fewer than 3 points after downsampling";
            return;
        }
        const Grid grid(a, max_dist);
        std::size_t inliers = 0;
        for (int it = 0; it < iterations; ++it) {
            Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(b.size())), dst(3, static_cast<Eigen::Index>(b.size()));
            Eigen::Index n = 0;
            for (const auto& p : b) {
                const Eigen::Vector3d q = T * p;
                double d2 = 0;
                const int j = grid.nearest(q, &d2);
                if (j < 0) continue;
                src.col(n) = p;
                dst.col(n) = a[static_cast<std::size_t>(j)];
                ++n;
            }
            inliers = static_cast<std::size_t>(n);
            if (n < 3) break;
            const Eigen::Matrix4d U = Eigen::umeyama(src.leftCols(n), dst.leftCols(n), false);
            const Eigen::Isometry3d next(U);
            const bool converged = (next.translation() - T.translation()).norm() < 1e-4 &&
                                   Eigen::AngleAxisd(next.linear().transpose() * T.linear()).angle() < 1e-5;
            T = next;
            if (converged) break;
        }
        const double share = static_cast<double>(inliers) / static_cast<double>(b.size());
        if (share < min_inliers) {
            r.reason = "only " + std::to_string(share) + " of B's points have a correspondence";
            return;
        }
        r.matched = true;
        r.status = PairStatus::kOk;
        const Eigen::Matrix4d M = T.matrix();
        for (int i = 0; i < 16; ++i) r.T_a_b[static_cast<std::size_t>(i)] = M(i / 4, i % 4);
    }
};

}  // namespace

int main(int argc, char** argv) {
    maptune::sdk::WorkerConfig config;
    if (const int code = maptune::sdk::parse_worker_args(
            argc, argv, "maptune icp_worker: odometry-seeded ICP matcher on the worker SDK", config);
        code >= 0) {
        return code;
    }
    IcpMatcher matcher;
    return maptune::sdk::run_worker(config, matcher);
}
