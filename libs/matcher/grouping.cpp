#include "matcher/grouping.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <tuple>

namespace maptune::matcher {

HoughGroups hough_groups(const SubmapFeatures& a, const SubmapFeatures& b,
                         const std::vector<Correspondence>& corrs, double v_tf, int n_tf) {
    HoughGroups out;
    if (!(v_tf > 0) || corrs.empty()) return out;
    // Model votes in each b keypoint's LRF, computed once per keypoint.
    std::vector<Eigen::Vector3f> local(static_cast<std::size_t>(b.num_keypoints()));
    for (int j = 0; j < b.num_keypoints(); ++j)
        local[static_cast<std::size_t>(j)] =
            b.lrfs[static_cast<std::size_t>(j)] * (b.keypoint_centroid - b.keypoints.col(j));
    std::map<std::tuple<std::int64_t, std::int64_t, std::int64_t>, std::vector<int>> bins;
    const double inv = 1.0 / v_tf;
    for (std::size_t c = 0; c < corrs.size(); ++c) {
        const auto& k = corrs[c];
        const Eigen::Vector3f vote =
            a.keypoints.col(k.a) + a.lrfs[static_cast<std::size_t>(k.a)].transpose() *
                                       local[static_cast<std::size_t>(k.b)];
        if (!vote.allFinite()) continue;
        bins[{static_cast<std::int64_t>(std::floor(vote.x() * inv)),
              static_cast<std::int64_t>(std::floor(vote.y() * inv)),
              static_cast<std::int64_t>(std::floor(vote.z() * inv))}]
            .push_back(static_cast<int>(c));
    }
    for (auto& [key, members] : bins) {
        out.largest_bin = std::max(out.largest_bin, static_cast<int>(members.size()));
        if (static_cast<int>(members.size()) >= n_tf) out.groups.push_back(std::move(members));
    }
    std::stable_sort(out.groups.begin(), out.groups.end(),
                     [](const auto& l, const auto& r) { return l.size() > r.size(); });
    return out;
}

bool is_collinear(const std::vector<Eigen::Vector3f>& points, double threshold_m,
                  double inlier_fraction, int iterations, std::uint64_t seed) {
    const int n = static_cast<int>(points.size());
    if (n < 3) return true;
    std::mt19937_64 rng(seed);
    const int needed = static_cast<int>(std::ceil(inlier_fraction * n));
    bool any_line = false;
    for (int it = 0; it < std::max(1, iterations); ++it) {
        const int i = static_cast<int>(rng() % static_cast<std::uint64_t>(n));
        const int j = static_cast<int>(rng() % static_cast<std::uint64_t>(n));
        const Eigen::Vector3f d =
            points[static_cast<std::size_t>(j)] - points[static_cast<std::size_t>(i)];
        if (d.norm() <= threshold_m) continue;  // too close to define a line
        any_line = true;
        const Eigen::Vector3f u = d.normalized();
        int inliers = 0;
        for (const auto& p : points) {
            const Eigen::Vector3f w = p - points[static_cast<std::size_t>(i)];
            if ((w - w.dot(u) * u).norm() <= threshold_m) ++inliers;
        }
        if (inliers >= needed) return true;
    }
    // All sampled pairs coincide: the points are (nearly) one point, which is degenerate too.
    return !any_line;
}

RigidRansacResult ransac_rigid(const Eigen::Matrix3Xf& points_a, const Eigen::Matrix3Xf& points_b,
                               double inlier_threshold_m, int iterations, std::uint64_t seed,
                               const Deadline& deadline) {
    RigidRansacResult out;
    const int n = static_cast<int>(points_a.cols());
    if (n < 3 || points_b.cols() != n || !(inlier_threshold_m > 0)) return out;
    const float thr2 = static_cast<float>(inlier_threshold_m * inlier_threshold_m);
    std::mt19937_64 rng(seed);
    auto count_inliers = [&](const Eigen::Matrix4f& T, std::vector<int>* idx) {
        const Eigen::Matrix3f R = T.topLeftCorner<3, 3>();
        const Eigen::Vector3f t = T.topRightCorner<3, 1>();
        int count = 0;
        for (int k = 0; k < n; ++k) {
            if ((R * points_b.col(k) + t - points_a.col(k)).squaredNorm() <= thr2) {
                ++count;
                if (idx) idx->push_back(k);
            }
        }
        return count;
    };
    int best = 0;
    Eigen::Matrix4f best_T = Eigen::Matrix4f::Identity();
    const float min_area = static_cast<float>(inlier_threshold_m * inlier_threshold_m * 1e-2);
    // Adaptive stop: enough iterations to draw one all-inlier sample with 99.9 % probability
    // at the best inlier ratio so far, capped by `iterations`.
    long long needed = std::max(1, iterations);
    for (long long it = 0; it < needed; ++it) {
        if ((it & 63) == 0 && deadline.expired()) {
            out.timed_out = true;
            return out;
        }
        int s[3];
        s[0] = static_cast<int>(rng() % static_cast<std::uint64_t>(n));
        s[1] = static_cast<int>(rng() % static_cast<std::uint64_t>(n));
        s[2] = static_cast<int>(rng() % static_cast<std::uint64_t>(n));
        if (s[0] == s[1] || s[1] == s[2] || s[0] == s[2]) continue;
        Eigen::Matrix3f A, B;
        for (int c = 0; c < 3; ++c) {
            A.col(c) = points_a.col(s[c]);
            B.col(c) = points_b.col(s[c]);
        }
        // Degenerate (collinear) samples give no unique rotation.
        if ((B.col(1) - B.col(0)).cross(B.col(2) - B.col(0)).norm() < min_area ||
            (A.col(1) - A.col(0)).cross(A.col(2) - A.col(0)).norm() < min_area)
            continue;
        const Eigen::Matrix4f T = Eigen::umeyama(B, A, false);
        if (!T.allFinite()) continue;
        const int c = count_inliers(T, nullptr);
        if (c > best) {
            best = c;
            best_T = T;
            if (best == n) break;
            const double w = static_cast<double>(best) / n;
            const double p_fail = 1.0 - w * w * w;
            if (p_fail > 0 && p_fail < 1) {
                const double k = std::log(1e-3) / std::log(p_fail);
                needed = std::min<long long>(needed, static_cast<long long>(std::ceil(k)) + 1);
                needed = std::max(needed, it + 1);
            }
        }
    }
    if (best < 3) return out;
    std::vector<int> idx;
    count_inliers(best_T, &idx);
    Eigen::Matrix3Xf A(3, static_cast<Eigen::Index>(idx.size())),
        B(3, static_cast<Eigen::Index>(idx.size()));
    for (std::size_t k = 0; k < idx.size(); ++k) {
        A.col(static_cast<Eigen::Index>(k)) = points_a.col(idx[k]);
        B.col(static_cast<Eigen::Index>(k)) = points_b.col(idx[k]);
    }
    Eigen::Matrix4f refined = Eigen::umeyama(B, A, false);
    if (refined.allFinite()) {
        std::vector<int> idx2;
        if (count_inliers(refined, &idx2) >= static_cast<int>(idx.size())) {
            best_T = refined;
            idx.swap(idx2);
        }
    }
    out.ok = true;
    out.T_a_b = best_T;
    out.inliers = std::move(idx);
    return out;
}

}  // namespace maptune::matcher
