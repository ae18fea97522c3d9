#include "matcher/descriptor_matching.hpp"

#include <gtest/gtest.h>

#include <random>
#include <tuple>

namespace maptune::matcher {
namespace {

// Structured random descriptors: B holds noisy copies of some rows of A plus unrelated rows,
// so distances spread over [0, 1] instead of concentrating like pure random vectors do.
std::pair<DescriptorMatrix, DescriptorMatrix> make_descriptors(int na, int nb, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    auto sparse_row = [&](DescriptorMatrix& M, int r) {
        for (int c = 0; c < M.cols(); ++c) M(r, c) = u(rng) < 0.3f ? u(rng) : 0.f;
    };
    DescriptorMatrix A(na, kDescriptorSize), B(nb, kDescriptorSize);
    for (int r = 0; r < na; ++r) sparse_row(A, r);
    for (int r = 0; r < nb; ++r) {
        if (r % 2 == 0) {
            const float noise = 0.05f + 0.5f * u(rng);
            B.row(r) = A.row(static_cast<int>(rng() % static_cast<unsigned>(na)));
            for (int c = 0; c < B.cols(); ++c)
                B(r, c) = std::max(0.f, B(r, c) + noise * (u(rng) - 0.5f));
        } else {
            sparse_row(B, r);
        }
    }
    A.rowwise().normalize();
    B.rowwise().normalize();
    return {A, B};
}

class DescriptorMatchingTest : public ::testing::TestWithParam<std::tuple<int, double, int>> {};

TEST_P(DescriptorMatchingTest, EqualsBruteForceOracle) {
    const auto [n_c, t_c, block] = GetParam();
    const auto [A, B] = make_descriptors(150, 130, 7u + static_cast<unsigned>(n_c));
    const auto fast = match_descriptors(A, B, n_c, t_c, block);
    const auto oracle = match_descriptors_brute_force(A, B, n_c, t_c);
    ASSERT_EQ(fast.size(), oracle.size());
    for (std::size_t i = 0; i < fast.size(); ++i) {
        EXPECT_EQ(fast[i].a, oracle[i].a) << i;
        EXPECT_EQ(fast[i].b, oracle[i].b) << i;
        EXPECT_NEAR(fast[i].distance, oracle[i].distance, 1e-3);
        EXPECT_GE(fast[i].distance, 0.f);
        EXPECT_LE(fast[i].distance, 1.f);
    }
}

TEST_P(DescriptorMatchingTest, CachedNeighbourListsGiveTheSameCorrespondences) {
    // One list of length 10 per pair serves every (n_C <= 10, t_C): the re-evaluation path.
    const auto [n_c, t_c, block] = GetParam();
    const auto [A, B] = make_descriptors(150, 130, 7u + static_cast<unsigned>(n_c));
    const auto lists = nearest_descriptors(A, B, 10, -2.0f, block);
    const auto selected = select_correspondences(lists, n_c, t_c);
    const auto oracle = match_descriptors_brute_force(A, B, n_c, t_c);
    ASSERT_EQ(selected.size(), oracle.size());
    for (std::size_t i = 0; i < selected.size(); ++i) {
        EXPECT_EQ(selected[i].a, oracle[i].a) << i;
        EXPECT_EQ(selected[i].b, oracle[i].b) << i;
        EXPECT_NEAR(selected[i].distance, oracle[i].distance, 1e-3);
    }
}

INSTANTIATE_TEST_SUITE_P(Variants, DescriptorMatchingTest,
                         ::testing::Values(std::make_tuple(1, 0.5, 256),
                                           std::make_tuple(3, 0.35, 64),
                                           std::make_tuple(3, 1.0, 17),
                                           std::make_tuple(10, 0.6, 1000),
                                           std::make_tuple(5, 0.2, 32)));

TEST(DescriptorMatching, IdenticalSetsMatchThemselves) {
    const auto [A, B] = make_descriptors(50, 2, 3);
    (void)B;
    const auto c = match_descriptors(A, A, 1, 0.1);
    ASSERT_EQ(c.size(), 50u);
    for (const auto& k : c) {
        EXPECT_EQ(k.a, k.b);
        EXPECT_NEAR(k.distance, 0.f, 2e-3);
    }
}

TEST(DescriptorMatching, EmptyAndZeroThreshold) {
    const auto [A, B] = make_descriptors(10, 10, 5);
    EXPECT_TRUE(match_descriptors(A, DescriptorMatrix(0, kDescriptorSize), 3, 0.5).empty());
    EXPECT_TRUE(match_descriptors(A, B, 3, 0.0).empty());
    EXPECT_TRUE(match_descriptors(A, B, 0, 0.5).empty());
}

}  // namespace
}  // namespace maptune::matcher
