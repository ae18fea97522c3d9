#pragma once
// Cholesky factorization A = L Lᵀ of a GP covariance matrix behind one interface, so the
// dense Eigen backend and the SuiteSparse CHOLMOD backend can be swapped and benchmarked.

#include <Eigen/Core>
#include <algorithm>
#include <memory>
#include <optional>
#include <string>

namespace maptune::gp {

enum class CholeskyBackend {
    eigen,    // Eigen LLT on a growable buffer; O(n²) append, O(1) truncate (default)
    cholmod,  // SuiteSparse CHOLMOD supernodal; refactorizes on append (see docs/optimizer.md)
};

std::string to_string(CholeskyBackend backend);
bool cholmod_available();

class Cholesky {
  public:
    virtual ~Cholesky() = default;
    virtual std::unique_ptr<Cholesky> clone() const = 0;

    // Factorizes the symmetric matrix a (its lower triangle is read). False if not positive
    // definite; the factor is then empty.
    virtual bool compute(const Eigen::MatrixXd& a) = 0;
    // Grows A by one row/column: cross = A(new, old), diag = A(new, new). False (and no
    // change) if the result is not positive definite.
    virtual bool append(const Eigen::VectorXd& cross, double diag) = 0;
    // Keeps the leading n×n block: its factor is the leading block of L (a downdate of the
    // trailing points, used to drop fantasized pending points).
    virtual void truncate(Eigen::Index n) = 0;

    virtual Eigen::Index size() const = 0;
    virtual Eigen::MatrixXd solve_lower(const Eigen::MatrixXd& b) const = 0;  // L⁻¹ b
    virtual Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const = 0;        // A⁻¹ b
    virtual Eigen::MatrixXd inverse() const;                                  // A⁻¹
    virtual double log_det() const = 0;                                       // log |A|

    // L itself (size() × size(), column-major) when the backend keeps it dense: the GP's
    // blocked prediction reads it directly. CHOLMOD's factor is supernodal: nullopt.
    using DenseLower = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>;
    virtual std::optional<DenseLower> dense_lower() const { return std::nullopt; }
};

std::unique_ptr<Cholesky> make_cholesky(CholeskyBackend backend);

// A⁻¹ from the lower Cholesky factor L of A (only its lower triangle is read), in n³/3
// multiply-adds; upper_inv receives L⁻ᵀ. Both outputs are resized; reusing them across calls
// avoids the allocations. `threads` (gp::resolve_threads units, 1 = the caller only) split
// the column blocks of L⁻ᵀ and the blocks of A⁻¹; each block is written by one task, so
// the result does not depend on the thread count.
void inverse_from_lower(const Eigen::Ref<const Eigen::MatrixXd>& l, Eigen::MatrixXd& upper_inv,
                        Eigen::MatrixXd& inverse, int threads = 1);

// Up to this size the dense routines below stay on one thread and use the small-matrix kernels
// (simd_kernels.hpp): starting threads costs more than the work (K⁻¹ at n = 100: 0.36 ms on 2
// threads, 0.09 ms on one).
constexpr Eigen::Index kSmallDense = 256;

// In-place lower Cholesky factor of the symmetric positive definite a (only its lower triangle
// is read; L overwrites it, the strict upper triangle is scratch). False if a is not positive
// definite. Above kSmallDense right-looking in blocks of 128 (up to it, left-looking by columns): the panel
// solves and the trailing update's blocks are split across `threads`, each block written by
// one task in a fixed order, so the factor does not depend on the thread count.
bool factorize_lower(Eigen::Ref<Eigen::MatrixXd> a, int threads = 1);

class EigenCholesky final : public Cholesky {
  public:
    std::unique_ptr<Cholesky> clone() const override;
    bool compute(const Eigen::MatrixXd& a) override;
    bool append(const Eigen::VectorXd& cross, double diag) override;
    void truncate(Eigen::Index n) override;
    Eigen::Index size() const override { return n_; }
    Eigen::MatrixXd solve_lower(const Eigen::MatrixXd& b) const override;
    Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const override;
    Eigen::MatrixXd inverse() const override;
    double log_det() const override;
    std::optional<DenseLower> dense_lower() const override {
        const Eigen::Index ld = std::max<Eigen::Index>(l_.rows(), 1);
        return DenseLower(l_.data(), n_, n_, Eigen::OuterStride<>(ld));
    }
    // Rank-1 update (sigma = +1) or downdate (sigma = -1) of A ± v vᵀ in O(n²).
    bool rank_update(const Eigen::VectorXd& v, double sigma);

  private:
    void reserve(Eigen::Index n);
    auto lower() const { return l_.topLeftCorner(n_, n_).triangularView<Eigen::Lower>(); }

    Eigen::MatrixXd l_;  // capacity × capacity; only the leading n_ × n_ lower block is valid
    Eigen::Index n_ = 0;
};

}  // namespace maptune::gp
