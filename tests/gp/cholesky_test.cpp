#include "gp/cholesky.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <random>

namespace maptune::gp {
namespace {

Eigen::MatrixXd random_spd(Eigen::Index n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal;
    Eigen::MatrixXd b(n, n);
    for (Eigen::Index i = 0; i < b.size(); ++i) b.data()[i] = normal(rng);
    return b * b.transpose() / static_cast<double>(n) + Eigen::MatrixXd::Identity(n, n);
}

class CholeskyTest : public ::testing::TestWithParam<CholeskyBackend> {
  protected:
    void SetUp() override {
        if (GetParam() == CholeskyBackend::cholmod && !cholmod_available()) {
            GTEST_SKIP() << "built without CHOLMOD";
        }
    }
};

TEST_P(CholeskyTest, SolvesAndLogDetMatchDenseOracle) {
    const Eigen::MatrixXd a = random_spd(40, 1);
    const Eigen::MatrixXd b = Eigen::MatrixXd::Random(40, 3);
    auto chol = make_cholesky(GetParam());
    ASSERT_TRUE(chol->compute(a));
    const Eigen::LLT<Eigen::MatrixXd> llt(a);
    EXPECT_LT((chol->solve(b) - a.fullPivLu().solve(b)).norm(), 1e-10);
    EXPECT_LT((chol->solve_lower(b) - llt.matrixL().solve(b)).norm(), 1e-10);
    EXPECT_LT((chol->inverse() - a.inverse()).norm(), 1e-10);
    EXPECT_NEAR(chol->log_det(), std::log(a.determinant()), 1e-9);
}

TEST_P(CholeskyTest, AppendMatchesFreshFactorization) {
    const Eigen::MatrixXd a = random_spd(30, 2);
    auto inc = make_cholesky(GetParam());
    ASSERT_TRUE(inc->compute(a.topLeftCorner(5, 5)));
    for (Eigen::Index n = 5; n < 30; ++n) {
        ASSERT_TRUE(inc->append(a.col(n).head(n), a(n, n)));
    }
    auto fresh = make_cholesky(GetParam());
    ASSERT_TRUE(fresh->compute(a));
    const Eigen::MatrixXd eye = Eigen::MatrixXd::Identity(30, 30);
    EXPECT_LT((inc->solve_lower(eye) - fresh->solve_lower(eye)).norm(), 1e-10);
    EXPECT_NEAR(inc->log_det(), fresh->log_det(), 1e-10);
}

TEST_P(CholeskyTest, TruncateKeepsLeadingBlock) {
    const Eigen::MatrixXd a = random_spd(20, 3);
    auto chol = make_cholesky(GetParam());
    ASSERT_TRUE(chol->compute(a));
    chol->truncate(12);
    ASSERT_EQ(chol->size(), 12);
    const Eigen::VectorXd b = Eigen::VectorXd::Ones(12);
    EXPECT_LT((chol->solve(b) - a.topLeftCorner(12, 12).llt().solve(b)).norm(), 1e-10);
}

TEST_P(CholeskyTest, RejectsIndefiniteAppend) {
    const Eigen::MatrixXd a = Eigen::MatrixXd::Identity(3, 3);
    auto chol = make_cholesky(GetParam());
    ASSERT_TRUE(chol->compute(a));
    EXPECT_FALSE(chol->append(Eigen::Vector3d(1.0, 1.0, 1.0), 1.0));
    EXPECT_EQ(chol->size(), 3);
}

// The blocked factorization and inverse (sizes off the block grid, odd remainders for the
// kernel's row and column tails) against Eigen's LLT and LU, and the same bits for every
// thread count.
TEST(BlockedCholeskyTest, FactorAndInverseMatchEigenForEveryThreadCount) {
    for (const Eigen::Index n : {5, 37, 100, 256, 300, 517}) {
        const Eigen::MatrixXd a = random_spd(n, 10 + static_cast<std::uint64_t>(n));
        const Eigen::MatrixXd oracle_l = Eigen::LLT<Eigen::MatrixXd>(a).matrixL();
        const Eigen::MatrixXd oracle_inv = a.inverse();
        Eigen::MatrixXd first_l, first_inv;
        for (const int threads : {1, 2, 3}) {
            Eigen::MatrixXd f = a;
            ASSERT_TRUE(factorize_lower(f, threads)) << n;
            const Eigen::MatrixXd l = f.triangularView<Eigen::Lower>();
            EXPECT_LT((l - oracle_l).norm(), 1e-10 * oracle_l.norm()) << n << " " << threads;
            Eigen::MatrixXd work, inv;
            inverse_from_lower(l, work, inv, threads);
            EXPECT_LT((inv - oracle_inv).norm(), 1e-10 * oracle_inv.norm()) << n << " " << threads;
            EXPECT_EQ(inv, inv.transpose());
            if (threads == 1) {
                first_l = l;
                first_inv = inv;
            } else {
                EXPECT_EQ(l, first_l) << n << " " << threads;
                EXPECT_EQ(inv, first_inv) << n << " " << threads;
            }
        }
    }
}

TEST(BlockedCholeskyTest, RejectsIndefiniteMatrix) {
    for (const Eigen::Index n : {10, 400}) {
        Eigen::MatrixXd a = random_spd(n, 5);
        a(n - 3, n - 3) = -1.0;  // breaks positive definiteness in the last block
        EXPECT_FALSE(factorize_lower(a, 2)) << n;
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, CholeskyTest,
                         ::testing::Values(CholeskyBackend::eigen, CholeskyBackend::cholmod),
                         [](const auto& tpi) { return to_string(tpi.param); });

TEST(EigenCholeskyTest, RankOneUpdateAndDowndate) {
    const Eigen::MatrixXd a = random_spd(25, 4);
    const Eigen::VectorXd v = 0.3 * Eigen::VectorXd::Random(25);
    EigenCholesky chol;
    ASSERT_TRUE(chol.compute(a));
    ASSERT_TRUE(chol.rank_update(v, 1.0));
    const Eigen::MatrixXd up = a + v * v.transpose();
    EXPECT_NEAR(chol.log_det(), std::log(up.determinant()), 1e-9);
    ASSERT_TRUE(chol.rank_update(v, -1.0));
    EXPECT_NEAR(chol.log_det(), std::log(a.determinant()), 1e-9);
    const Eigen::VectorXd b = Eigen::VectorXd::Ones(25);
    EXPECT_LT((chol.solve(b) - a.llt().solve(b)).norm(), 1e-9);
}

}  // namespace
}  // namespace maptune::gp
