#include "fpfh_matcher.hpp"

#include <pcl/features/fpfh.h>
#include <pcl/features/normal_3d.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

namespace maptune::fpfh {

struct Prepared {
    pcl::PointCloud<pcl::PointXYZ>::Ptr points{new pcl::PointCloud<pcl::PointXYZ>};
    pcl::PointCloud<pcl::FPFHSignature33>::Ptr features{new pcl::PointCloud<pcl::FPFHSignature33>};
    pcl::KdTreeFLANN<pcl::PointXYZ> point_tree;
    pcl::KdTreeFLANN<pcl::FPFHSignature33> feature_tree;
};

namespace {

double since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Centroid of each occupied voxel (our own grid: PCL's VoxelGrid gives up, returning the input,
// when a small leaf over a large extent overflows its 32-bit index).
std::vector<Eigen::Vector3f> voxel_centroids(const std::vector<Eigen::Vector3f>& points, double leaf) {
    struct Cell {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        int n = 0;
    };
    std::unordered_map<std::uint64_t, Cell> cells;
    cells.reserve(points.size() / 4 + 1);
    const auto coord = [&](float v) {
        return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v / leaf)) & 0x1fffff);
    };
    for (const auto& p : points) {
        if (!p.allFinite()) continue;
        auto& c = cells[(coord(p.x()) << 42) | (coord(p.y()) << 21) | coord(p.z())];
        c.sum += p.cast<double>();
        ++c.n;
    }
    std::vector<Eigen::Vector3f> out;
    out.reserve(cells.size());
    for (const auto& [key, c] : cells) out.push_back((c.sum / c.n).cast<float>());
    // Hash order depends on the library: sort so that results are the same everywhere.
    std::sort(out.begin(), out.end(), [](const auto& l, const auto& r) {
        return std::tie(l.x(), l.y(), l.z()) < std::tie(r.x(), r.y(), r.z());
    });
    return out;
}

double require(const std::map<std::string, double>& values, const std::string& key, double lo, double hi) {
    const auto it = values.find(key);
    if (it == values.end()) throw std::invalid_argument("parameter '" + key + "' is missing");
    if (!std::isfinite(it->second) || it->second < lo || it->second > hi)
        throw std::invalid_argument("parameter '" + key + "' = " + std::to_string(it->second) +
                                    " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return it->second;
}

}  // namespace

Params params_from(const std::map<std::string, double>& values) {
    Params p;
    // Scales beyond 20 voxels would make the work per point explode (the design space stops
    // far earlier); voxels below 10 µm overflow the grid's 21-bit cell coordinates sooner.
    p.voxel_m = require(values, "voxel_m", 1e-5, 1e3);
    p.normal_scale = require(values, "normal_scale", 1, 20);
    p.feature_scale = require(values, "feature_scale", 1, 20);
    p.n_corr = static_cast<int>(std::lround(require(values, "n_corr", 1, 50)));
    p.similarity = require(values, "similarity", 0, 1);
    p.inlier_scale = require(values, "inlier_scale", 0.1, 20);
    p.gicp_scale = require(values, "gicp_scale", 0.1, 20);
    p.min_overlap = require(values, "min_overlap", 0, 1);
    return p;
}

const std::vector<std::string>& param_names() {
    static const std::vector<std::string> names = {"voxel_m",      "normal_scale", "feature_scale", "n_corr",
                                                   "similarity",   "inlier_scale", "gicp_scale",    "min_overlap"};
    return names;
}

PrepareResult prepare(const std::vector<Eigen::Vector3f>& points, const Params& params) {
    const auto t0 = std::chrono::steady_clock::now();
    PrepareResult out;
    const auto thinned = voxel_centroids(points, params.voxel_m);
    out.points = static_cast<int>(thinned.size());
    if (thinned.size() < 10) {
        out.reason = "only " + std::to_string(thinned.size()) + " points after the voxel grid";
        out.seconds = since(t0);
        return out;
    }
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->reserve(thinned.size());
    for (const auto& p : thinned) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));

    // Normals face the frame's origin (the sensor of a scan, the robot of a submap), so that
    // both clouds of a pair orient them alike.
    pcl::PointCloud<pcl::Normal>::Ptr normals(new pcl::PointCloud<pcl::Normal>);
    pcl::search::KdTree<pcl::PointXYZ>::Ptr search(new pcl::search::KdTree<pcl::PointXYZ>);
    pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
    ne.setInputCloud(cloud);
    ne.setSearchMethod(search);
    ne.setRadiusSearch(params.normal_radius_m());
    ne.setViewPoint(0, 0, 0);
    ne.compute(*normals);

    pcl::PointCloud<pcl::FPFHSignature33> fpfh;
    pcl::FPFHEstimation<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> fe;
    fe.setInputCloud(cloud);
    fe.setInputNormals(normals);
    fe.setSearchMethod(search);
    fe.setRadiusSearch(params.feature_radius_m());
    fe.compute(fpfh);

    // Points without a normal or a histogram (too few neighbours) cannot be matched.
    auto prepared = std::make_shared<Prepared>();
    for (std::size_t i = 0; i < cloud->size(); ++i) {
        const auto& n = (*normals)[i];
        const auto& h = fpfh[i];
        bool ok = std::isfinite(n.normal_x) && std::isfinite(n.normal_y) && std::isfinite(n.normal_z);
        float mass = 0;
        for (float v : h.histogram) {
            ok = ok && std::isfinite(v);
            mass += v;
        }
        if (!ok || mass <= 0) continue;
        prepared->points->push_back((*cloud)[i]);
        prepared->features->push_back(h);
    }
    if (prepared->points->size() < 10) {
        out.reason = "only " + std::to_string(prepared->points->size()) + " of " +
                     std::to_string(cloud->size()) + " points have normals and FPFH (radii too small?)";
        out.seconds = since(t0);
        return out;
    }
    prepared->point_tree.setInputCloud(prepared->points);
    prepared->feature_tree.setInputCloud(prepared->features);
    out.cloud = std::move(prepared);
    out.seconds = since(t0);
    return out;
}

PairOutcome register_pair(const Prepared& a, const Prepared& b, const Params& params,
                          const Settings& settings, std::uint64_t seed) {
    const auto t0 = std::chrono::steady_clock::now();
    PairOutcome out;
    const auto deadline = t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                   std::chrono::duration<double>(settings.pair_time_limit_s));
    const auto time_out = [&](const char* where) {
        out.timed_out = true;
        out.reason = std::string("pair time limit of ") + std::to_string(settings.pair_time_limit_s) + " s " + where;
        out.seconds = since(t0);
        return out;
    };
    // Candidate correspondences: each B point to its n_corr nearest A histograms.
    std::vector<std::pair<int, int>> corrs;  // (b index, a index)
    const int k = std::min<int>(params.n_corr, static_cast<int>(a.features->size()));
    corrs.reserve(b.features->size() * static_cast<std::size_t>(k));
    pcl::Indices idx(static_cast<std::size_t>(k));
    std::vector<float> d2(static_cast<std::size_t>(k));
    for (std::size_t i = 0; i < b.features->size(); ++i) {
        if (a.feature_tree.nearestKSearch((*b.features)[i], k, idx, d2) <= 0) continue;
        for (const auto j : idx) corrs.emplace_back(static_cast<int>(i), static_cast<int>(j));
    }
    out.correspondences = static_cast<int>(corrs.size());
    if (std::chrono::steady_clock::now() > deadline) return time_out("in the correspondence search");
    if (corrs.size() < 3) {
        out.reason = "too few correspondences";
        out.seconds = since(t0);
        return out;
    }
    const auto pa = [&](int j) { return (*a.points)[static_cast<std::size_t>(j)].getVector3fMap(); };
    const auto pb = [&](int i) { return (*b.points)[static_cast<std::size_t>(i)].getVector3fMap(); };
    const float thr2 = static_cast<float>(params.inlier_m() * params.inlier_m());
    const auto count_inliers = [&](const Eigen::Matrix4f& T, std::vector<int>* members) {
        const Eigen::Matrix3f R = T.topLeftCorner<3, 3>();
        const Eigen::Vector3f t = T.topRightCorner<3, 1>();
        int n = 0;
        for (std::size_t c = 0; c < corrs.size(); ++c) {
            if ((R * pb(corrs[c].first) + t - pa(corrs[c].second)).squaredNorm() <= thr2) {
                ++n;
                if (members) members->push_back(static_cast<int>(c));
            }
        }
        return n;
    };

    std::mt19937_64 rng(seed);
    std::uniform_int_distribution<std::size_t> pick(0, corrs.size() - 1);
    const float min_area = thr2 * 0.25f;  // a sliver triangle fixes no rotation
    int best = 0;
    Eigen::Matrix4f best_T = Eigen::Matrix4f::Identity();
    long long needed = settings.ransac_max_draws;
    for (long long draw = 0; draw < needed; ++draw) {
        if ((draw & 255) == 0 && std::chrono::steady_clock::now() > deadline) return time_out("in RANSAC");
        std::size_t s[3] = {pick(rng), pick(rng), pick(rng)};
        Eigen::Matrix3f A, B;
        for (int c = 0; c < 3; ++c) {
            A.col(c) = pa(corrs[s[c]].second);
            B.col(c) = pb(corrs[s[c]].first);
        }
        // Pre-rejection: a rigid motion keeps edge lengths.
        bool similar = true;
        for (int e = 0; e < 3 && similar; ++e) {
            const float la = (A.col(e) - A.col((e + 1) % 3)).norm();
            const float lb = (B.col(e) - B.col((e + 1) % 3)).norm();
            const float hi = std::max(la, lb);
            similar = hi > 0 && std::min(la, lb) / hi >= params.similarity;
        }
        if (!similar) continue;
        if ((A.col(1) - A.col(0)).cross(A.col(2) - A.col(0)).norm() < min_area) continue;
        const Eigen::Matrix4f T = Eigen::umeyama(B, A, false);
        if (!T.allFinite()) continue;
        const int n = count_inliers(T, nullptr);
        if (n <= best) continue;
        best = n;
        best_T = T;
        const double w = static_cast<double>(best) / static_cast<double>(corrs.size());
        const double p_fail = 1.0 - w * w * w;
        if (p_fail <= 0) break;
        if (p_fail < 1)
            needed = std::min<long long>(needed, std::max<long long>(
                                                     draw + 1, static_cast<long long>(std::ceil(
                                                                   std::log(1e-3) / std::log(p_fail)))));
    }
    if (best < 3) {
        out.reason = "RANSAC found no rigid transform with 3 inliers";
        out.seconds = since(t0);
        return out;
    }
    // Refit on all inliers of the best hypothesis.
    std::vector<int> members;
    count_inliers(best_T, &members);
    Eigen::Matrix3Xf A(3, static_cast<Eigen::Index>(members.size())), B(3, static_cast<Eigen::Index>(members.size()));
    for (std::size_t m = 0; m < members.size(); ++m) {
        A.col(static_cast<Eigen::Index>(m)) = pa(corrs[static_cast<std::size_t>(members[m])].second);
        B.col(static_cast<Eigen::Index>(m)) = pb(corrs[static_cast<std::size_t>(members[m])].first);
    }
    const Eigen::Matrix4f refit = Eigen::umeyama(B, A, false);
    if (refit.allFinite() && count_inliers(refit, nullptr) >= best) best_T = refit;
    out.ransac_inliers = count_inliers(best_T, nullptr);

    // GICP on the downsampled clouds, from the RANSAC transform.
    Eigen::Matrix4f T = best_T;
    {
        pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
        gicp.setInputSource(b.points);
        gicp.setInputTarget(a.points);
        gicp.setMaxCorrespondenceDistance(params.gicp_max_dist_m());
        gicp.setMaximumIterations(settings.gicp_iterations);
        gicp.setTransformationEpsilon(1e-8);
        pcl::PointCloud<pcl::PointXYZ> aligned;
        gicp.align(aligned, best_T);
        if (gicp.hasConverged() && gicp.getFinalTransformation().allFinite()) T = gicp.getFinalTransformation();
    }
    out.T_a_b = T.cast<double>();

    // Decision: enough of B lies on A after registration.
    int near = 0;
    pcl::Indices one(1);
    std::vector<float> one_d2(1);
    for (const auto& p : *b.points) {
        pcl::PointXYZ q;
        q.getVector3fMap() = T.topLeftCorner<3, 3>() * p.getVector3fMap() + T.topRightCorner<3, 1>();
        if (a.point_tree.nearestKSearch(q, 1, one, one_d2) > 0 && one_d2[0] <= thr2) ++near;
    }
    out.overlap = static_cast<double>(near) / static_cast<double>(b.points->size());
    if (out.overlap < params.min_overlap) {
        out.reason = "overlap " + std::to_string(out.overlap) + " after GICP is below min_overlap";
        out.seconds = since(t0);
        return out;
    }
    out.matched = true;
    out.seconds = since(t0);
    return out;
}

}  // namespace maptune::fpfh
