// DirectKdTree must answer exactly as PCL's own k-d tree (same neighbours, order, distances):
// the matcher swapped it in for speed, not for different results.
#include "matcher/direct_kdtree.hpp"

#include <gtest/gtest.h>
#include <pcl/point_types.h>

#include <limits>
#include <random>

namespace maptune::matcher {
namespace {

template <typename PointT>
typename pcl::PointCloud<PointT>::Ptr random_cloud(int n, unsigned seed) {
    std::mt19937 rng(seed);
    // Points on a coarse grid as well as random ones, so that equal distances (ties) occur.
    std::uniform_real_distribution<float> u(-2.f, 2.f);
    std::uniform_int_distribution<int> g(-10, 10);
    typename pcl::PointCloud<PointT>::Ptr c(new pcl::PointCloud<PointT>);
    for (int i = 0; i < n; ++i) {
        PointT p;
        if (i % 3 == 0) {
            p.x = 0.1f * g(rng), p.y = 0.1f * g(rng), p.z = 0.1f * g(rng);
        } else {
            p.x = u(rng), p.y = u(rng), p.z = u(rng);
        }
        c->push_back(p);
    }
    (*c)[5].x = std::numeric_limits<float>::quiet_NaN();  // left out by both trees
    return c;
}

template <typename PointT>
void expect_same_answers(bool sorted, bool with_indices) {
    const auto cloud = random_cloud<PointT>(3000, sorted ? 1 : 2);
    pcl::IndicesPtr subset;
    if (with_indices) {
        subset.reset(new pcl::Indices);
        for (int i = 0; i < 3000; i += 2) subset->push_back(i);
    }
    pcl::search::KdTree<PointT> pcl_tree(sorted);
    DirectKdTree<PointT> direct(sorted);
    pcl_tree.setInputCloud(cloud, subset);
    direct.setInputCloud(cloud, subset);
    const auto queries = random_cloud<PointT>(200, 7);
    pcl::Indices ia, ib;
    std::vector<float> da, db;
    int checked = 0;
    for (std::size_t q = 0; q < queries->size(); ++q) {
        const PointT& p = (*queries)[q];
        if (!std::isfinite(p.x)) continue;
        for (const int k : {1, 7, 300}) {  // 300: FLANN's heap result set
            const int na = pcl_tree.nearestKSearch(p, k, ia, da);
            const int nb = direct.nearestKSearch(p, k, ib, db);
            ASSERT_EQ(na, nb) << "k " << k;
            ASSERT_EQ(ia, ib) << "k " << k << ", query " << q;
            ASSERT_EQ(da, db) << "k " << k << ", query " << q;
        }
        for (const unsigned max_nn : {0u, 5u}) {
            const int na = pcl_tree.radiusSearch(p, 0.35, ia, da, max_nn);
            const int nb = direct.radiusSearch(p, 0.35, ib, db, max_nn);
            ASSERT_EQ(na, nb) << "max_nn " << max_nn;
            ASSERT_EQ(ia, ib) << "max_nn " << max_nn << ", query " << q;
            ASSERT_EQ(da, db) << "max_nn " << max_nn << ", query " << q;
            checked += na;
        }
    }
    EXPECT_GT(checked, 1000);  // the radius reached many points: the comparison meant something
}

TEST(DirectKdTreeTest, AnswersExactlyAsPclSortedAndUnsorted) {
    expect_same_answers<pcl::PointXYZRGBA>(true, false);
    expect_same_answers<pcl::PointXYZRGBA>(false, false);
    expect_same_answers<pcl::PointNormal>(true, false);
    expect_same_answers<pcl::PointXYZRGBA>(false, true);
}

TEST(DirectKdTreeTest, EmptyCloudFindsNothing) {
    DirectKdTree<pcl::PointNormal> tree;
    tree.setInputCloud(pcl::PointCloud<pcl::PointNormal>::Ptr(new pcl::PointCloud<pcl::PointNormal>));
    pcl::Indices i;
    std::vector<float> d;
    pcl::PointNormal p;
    p.x = p.y = p.z = 0.f;
    EXPECT_EQ(tree.nearestKSearch(p, 3, i, d), 0);
    EXPECT_TRUE(i.empty());
    EXPECT_EQ(tree.radiusSearch(p, 1.0, i, d), 0);
    EXPECT_TRUE(i.empty());
}

}  // namespace
}  // namespace maptune::matcher
