#include "gp/cholesky.hpp"
#include "gp/parallel.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace maptune::gp {

std::unique_ptr<Cholesky> make_cholmod_cholesky();  // cholmod_cholesky.cpp

std::string to_string(CholeskyBackend backend) {
    return backend == CholeskyBackend::eigen ? "eigen" : "cholmod";
}

bool cholmod_available() {
#ifdef MAPTUNE_GP_HAVE_CHOLMOD
    return true;
#else
    return false;
#endif
}

std::unique_ptr<Cholesky> make_cholesky(CholeskyBackend backend) {
    if (backend == CholeskyBackend::cholmod) {
#ifdef MAPTUNE_GP_HAVE_CHOLMOD
        return make_cholmod_cholesky();
#else
        throw std::invalid_argument("maptune_gp was built without CHOLMOD");
#endif
    }
    return std::make_unique<EigenCholesky>();
}

Eigen::MatrixXd Cholesky::inverse() const {
    return solve(Eigen::MatrixXd::Identity(size(), size()));
}

std::unique_ptr<Cholesky> EigenCholesky::clone() const {
    return std::make_unique<EigenCholesky>(*this);
}

void EigenCholesky::reserve(Eigen::Index n) {
    if (n <= l_.rows()) return;
    // Geometric growth keeps appends amortized O(n²).
    const Eigen::Index cap = std::max<Eigen::Index>(n, 2 * l_.rows());
    Eigen::MatrixXd grown = Eigen::MatrixXd::Zero(cap, cap);
    grown.topLeftCorner(n_, n_) = l_.topLeftCorner(n_, n_);
    l_.swap(grown);
}

bool EigenCholesky::compute(const Eigen::MatrixXd& a) {
    n_ = 0;
    Eigen::LLT<Eigen::MatrixXd> llt(a);
    if (llt.info() != Eigen::Success) return false;
    reserve(a.rows());
    n_ = a.rows();
    l_.topLeftCorner(n_, n_) = llt.matrixL();
    return true;
}

bool EigenCholesky::append(const Eigen::VectorXd& cross, double diag) {
    Eigen::VectorXd row = cross;
    if (n_ > 0) lower().solveInPlace(row);
    const double d2 = diag - row.squaredNorm();
    if (!(d2 > 0.0)) return false;
    reserve(n_ + 1);
    l_.row(n_).head(n_) = row.transpose();
    l_(n_, n_) = std::sqrt(d2);
    ++n_;
    return true;
}

void EigenCholesky::truncate(Eigen::Index n) { n_ = std::min(n, n_); }

Eigen::MatrixXd EigenCholesky::solve_lower(const Eigen::MatrixXd& b) const {
    Eigen::MatrixXd x = b;
    lower().solveInPlace(x);
    return x;
}

Eigen::MatrixXd EigenCholesky::solve(const Eigen::MatrixXd& b) const {
    Eigen::MatrixXd x = b;
    lower().solveInPlace(x);
    l_.topLeftCorner(n_, n_).transpose().triangularView<Eigen::Upper>().solveInPlace(x);
    return x;
}

void inverse_from_lower(const Eigen::Ref<const Eigen::MatrixXd>& l, Eigen::MatrixXd& linv,
                        Eigen::MatrixXd& inverse, int threads) {
    // A⁻¹ = L⁻ᵀ L⁻¹, both factors triangular. In blocks that skip their zeros (a column block of
    // L⁻¹ is zero above its diagonal block) this takes ~n³/3 multiply-adds instead of the ~n³
    // of dense solves and a dense product.
    const Eigen::Index n = l.rows();
    const Eigen::Index block = 32;
    const int blocks = static_cast<int>((n + block - 1) / block);
    linv.setZero(n, n);
    // Column block b of L⁻¹: rows from its diagonal block down, one triangular solve.
    parallel_for(blocks, threads, [&](int b) {
        const Eigen::Index j0 = b * block;
        const Eigen::Index w = std::min(block, n - j0);
        const Eigen::Index rows = n - j0;
        auto columns = linv.block(j0, j0, rows, w);
        columns.topRows(w).setIdentity();
        l.block(j0, j0, rows, rows).triangularView<Eigen::Lower>().solveInPlace(columns);
    });
    // Row block I of the lower triangle of A⁻¹: A⁻¹(I, 0:I+h) = L⁻¹(I:, I)ᵀ L⁻¹(I:, 0:I+h),
    // as L⁻¹(k, i) = 0 for k < i. Blocks go to threads in an interleaved order (their work
    // varies with I).
    inverse.resize(n, n);
    parallel_for(blocks, threads, [&](int b) {
        const Eigen::Index i0 = b * block;
        const Eigen::Index h = std::min(block, n - i0);
        const Eigen::Index rows = n - i0;
        inverse.block(i0, 0, h, i0 + h).noalias() =
            linv.block(i0, i0, rows, h).transpose() * linv.block(i0, 0, rows, i0 + h);
    });
    for (Eigen::Index j = 1; j < n; ++j) {
        inverse.col(j).head(j) = inverse.row(j).head(j).transpose();
    }
}

Eigen::MatrixXd EigenCholesky::inverse() const {
    Eigen::MatrixXd linv, inv;
    inverse_from_lower(l_.topLeftCorner(n_, n_), linv, inv);
    return inv;
}

double EigenCholesky::log_det() const {
    return 2.0 * l_.topLeftCorner(n_, n_).diagonal().array().log().sum();
}

bool EigenCholesky::rank_update(const Eigen::VectorXd& v, double sigma) {
    // Classic O(n²) column sweep on L (Golub & Van Loan); a failed downdate leaves L intact.
    const Eigen::MatrixXd backup = l_.topLeftCorner(n_, n_);
    Eigen::VectorXd w = v;
    for (Eigen::Index k = 0; k < n_; ++k) {
        const double lkk = l_(k, k);
        const double r2 = lkk * lkk + sigma * w(k) * w(k);
        if (!(r2 > 0.0)) {
            l_.topLeftCorner(n_, n_) = backup;
            return false;
        }
        const double r = std::sqrt(r2);
        const double c = r / lkk;
        const double s = w(k) / lkk;
        l_(k, k) = r;
        const Eigen::Index rest = n_ - k - 1;
        if (rest > 0) {
            auto col = l_.col(k).segment(k + 1, rest);
            auto tail = w.segment(k + 1, rest);
            col = (col + sigma * s * tail) / c;
            tail = c * tail - s * col;
        }
    }
    return true;
}

}  // namespace maptune::gp
