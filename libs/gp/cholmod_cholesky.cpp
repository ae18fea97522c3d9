// SuiteSparse CHOLMOD backend. GP covariance matrices are dense, so CHOLMOD runs its
// supernodal path (one dense supernode, LAPACK potrf) with the natural ordering; this file
// exists so the two backends can be compared on equal terms (bench/gp).
#include <cholmod.h>

#include <cmath>
#include <stdexcept>

#include "gp/cholesky.hpp"

namespace maptune::gp {

namespace {

class CholmodCholesky final : public Cholesky {
  public:
    CholmodCholesky() {
        cholmod_start(&common_);
        common_.nmethods = 1;
        common_.method[0].ordering = CHOLMOD_NATURAL;  // keeps L⁻¹ free of permutations
        common_.postorder = 0;
        common_.supernodal = CHOLMOD_SUPERNODAL;
        common_.print = 0;
        common_.error_handler = nullptr;
    }
    ~CholmodCholesky() override {
        free_factor();
        cholmod_finish(&common_);
    }
    CholmodCholesky(const CholmodCholesky&) = delete;
    CholmodCholesky& operator=(const CholmodCholesky&) = delete;

    std::unique_ptr<Cholesky> clone() const override {
        auto copy = std::make_unique<CholmodCholesky>();
        if (a_.size() > 0) copy->compute(a_);
        return copy;
    }

    bool compute(const Eigen::MatrixXd& a) override {
        a_ = a;
        return factorize();
    }

    bool append(const Eigen::VectorXd& cross, double diag) override {
        // CHOLMOD's rowadd works on simplicial LDLᵀ factors only; for dense GP matrices a fresh
        // supernodal factorization is what it offers, so append costs O(n³) here.
        const Eigen::Index n = a_.rows();
        Eigen::MatrixXd grown(n + 1, n + 1);
        grown.topLeftCorner(n, n) = a_;
        grown.col(n).head(n) = cross;
        grown.row(n).head(n) = cross.transpose();
        grown(n, n) = diag;
        Eigen::MatrixXd old = std::move(a_);
        a_ = std::move(grown);
        if (factorize()) return true;
        a_ = std::move(old);
        factorize();
        return false;
    }

    void truncate(Eigen::Index n) override {
        if (n >= a_.rows()) return;
        a_ = a_.topLeftCorner(n, n).eval();
        factorize();
    }

    Eigen::Index size() const override { return factor_ != nullptr ? a_.rows() : 0; }

    Eigen::MatrixXd solve_lower(const Eigen::MatrixXd& b) const override {
        return solve_system(CHOLMOD_L, b);
    }
    Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const override {
        return solve_system(CHOLMOD_A, b);
    }

    double log_det() const override {
        double sum = 0.0;
        const auto* super = static_cast<const int*>(factor_->super);
        const auto* pi = static_cast<const int*>(factor_->pi);
        const auto* px = static_cast<const int*>(factor_->px);
        const auto* x = static_cast<const double*>(factor_->x);
        for (std::size_t s = 0; s < factor_->nsuper; ++s) {
            const int ncols = super[s + 1] - super[s];
            const int nrows = pi[s + 1] - pi[s];
            for (int j = 0; j < ncols; ++j) sum += std::log(x[px[s] + j * nrows + j]);
        }
        return 2.0 * sum;
    }

  private:
    void free_factor() {
        if (factor_ != nullptr) cholmod_free_factor(&factor_, &common_);
    }

    bool factorize() {
        free_factor();
        const auto n = static_cast<std::size_t>(a_.rows());
        if (n == 0) return false;
        cholmod_sparse* a =
            cholmod_allocate_sparse(n, n, n * (n + 1) / 2, 1, 1, -1, CHOLMOD_REAL, &common_);
        auto* ap = static_cast<int*>(a->p);
        auto* ai = static_cast<int*>(a->i);
        auto* ax = static_cast<double*>(a->x);
        int nz = 0;
        for (std::size_t j = 0; j < n; ++j) {
            ap[j] = nz;
            for (std::size_t i = j; i < n; ++i, ++nz) {
                ai[nz] = static_cast<int>(i);
                ax[nz] = a_(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
            }
        }
        ap[n] = nz;
        factor_ = cholmod_analyze(a, &common_);
        const bool ok = factor_ != nullptr && cholmod_factorize(a, factor_, &common_) != 0 &&
                        common_.status == CHOLMOD_OK;
        cholmod_free_sparse(&a, &common_);
        if (!ok) free_factor();
        return ok;
    }

    Eigen::MatrixXd solve_system(int system, const Eigen::MatrixXd& b) const {
        if (factor_ == nullptr) throw std::logic_error("CholmodCholesky: no factor");
        cholmod_dense rhs{};
        rhs.nrow = static_cast<std::size_t>(b.rows());
        rhs.ncol = static_cast<std::size_t>(b.cols());
        rhs.nzmax = rhs.nrow * rhs.ncol;
        rhs.d = rhs.nrow;
        rhs.x = const_cast<double*>(b.data());  // CHOLMOD reads it only
        rhs.xtype = CHOLMOD_REAL;
        rhs.dtype = CHOLMOD_DOUBLE;
        cholmod_dense* sol = cholmod_solve(system, factor_, &rhs, &common_);
        Eigen::MatrixXd out =
            Eigen::Map<Eigen::MatrixXd>(static_cast<double*>(sol->x), b.rows(), b.cols());
        cholmod_free_dense(&sol, &common_);
        return out;
    }

    Eigen::MatrixXd a_;
    mutable cholmod_common common_{};
    cholmod_factor* factor_ = nullptr;
};

}  // namespace

std::unique_ptr<Cholesky> make_cholmod_cholesky() { return std::make_unique<CholmodCholesky>(); }

}  // namespace maptune::gp
