#include "matcher/grouping.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

namespace maptune::matcher {
namespace {

Eigen::Isometry3f some_transform() {
    Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
    T.linear() =
        (Eigen::AngleAxisf(0.7f, Eigen::Vector3f(0.2f, 0.3f, 1.f).normalized())).toRotationMatrix();
    T.translation() = Eigen::Vector3f(1.0f, -2.0f, 0.5f);
    return T;
}

TEST(RansacRigid, RecoversTransformWithOutliers) {
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(-3.f, 3.f);
    const auto T = some_transform();
    const int n = 60;
    Eigen::Matrix3Xf a(3, n), b(3, n);
    for (int i = 0; i < n; ++i) {
        b.col(i) = Eigen::Vector3f(u(rng), u(rng), u(rng));
        a.col(i) = i < 40 ? Eigen::Vector3f(T * Eigen::Vector3f(b.col(i)))
                          : Eigen::Vector3f(u(rng), u(rng), u(rng));
    }
    const auto r = ransac_rigid(a, b, 0.05, 500, 42);
    ASSERT_TRUE(r.ok);
    EXPECT_EQ(r.inliers.size(), 40u);
    EXPECT_TRUE(r.T_a_b.isApprox(T.matrix(), 1e-4f));
    // Deterministic given the seed.
    const auto r2 = ransac_rigid(a, b, 0.05, 500, 42);
    EXPECT_EQ(r.T_a_b, r2.T_a_b);
}

TEST(RansacRigid, DegenerateInputFails) {
    Eigen::Matrix3Xf a(3, 5), b(3, 5);
    for (int i = 0; i < 5; ++i) a.col(i) = b.col(i) = Eigen::Vector3f(float(i), 0.f, 0.f);
    EXPECT_FALSE(ransac_rigid(a, b, 0.05, 200, 1).ok);  // collinear: no unique rotation
    EXPECT_FALSE(ransac_rigid(a.leftCols(2), b.leftCols(2), 0.05, 200, 1).ok);
}

TEST(Collinearity, LineVersusPlane) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.f, 2.f), e(-0.01f, 0.01f);
    std::vector<Eigen::Vector3f> line, plane;
    for (int i = 0; i < 30; ++i) {
        const float t = u(rng);
        line.emplace_back(t, 2 * t + e(rng), e(rng));
        plane.emplace_back(u(rng), u(rng), e(rng));
    }
    EXPECT_TRUE(is_collinear(line, 0.05, 0.9, 100, 1));
    EXPECT_FALSE(is_collinear(plane, 0.05, 0.9, 100, 1));
    EXPECT_TRUE(is_collinear({Eigen::Vector3f::Zero(), Eigen::Vector3f::Ones()}, 0.05, 0.9, 10, 1));
}

TEST(Hough, ConsistentCorrespondencesShareOneBin) {
    // b's keypoints moved by T into a; LRFs rotate with the points, so all votes coincide.
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-2.f, 2.f);
    const auto T = some_transform();
    SubmapFeatures a, b;
    const int n = 20;
    a.keypoints.resize(3, n);
    b.keypoints.resize(3, n);
    std::vector<Correspondence> corrs;
    for (int i = 0; i < n; ++i) {
        b.keypoints.col(i) = Eigen::Vector3f(u(rng), u(rng), u(rng));
        a.keypoints.col(i) = T * Eigen::Vector3f(b.keypoints.col(i));
        const Eigen::Matrix3f Rb =
            Eigen::AngleAxisf(u(rng), Eigen::Vector3f(u(rng), u(rng), 1.f).normalized())
                .toRotationMatrix();
        b.lrfs.push_back(Rb);                           // rows = axes in b
        a.lrfs.push_back(Rb * T.linear().transpose());  // same axes expressed in a
        corrs.push_back({i, i, 0.1f});
    }
    b.keypoint_centroid = b.keypoints.rowwise().mean();
    // Plus 5 inconsistent correspondences.
    for (int i = 0; i < 5; ++i) corrs.push_back({i, (i + 7) % n, 0.2f});
    const auto g = hough_groups(a, b, corrs, 0.2, 8);
    ASSERT_FALSE(g.groups.empty());
    EXPECT_GE(g.groups.front().size(), static_cast<std::size_t>(n) - 2);  // bin edges
    EXPECT_TRUE(hough_groups(a, b, corrs, 0.2, 100).groups.empty());
}

}  // namespace
}  // namespace maptune::matcher
