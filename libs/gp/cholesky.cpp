#include "gp/cholesky.hpp"
#include "gp/parallel.hpp"
#include "gp/simd_kernels.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>
#include <vector>

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
    reserve(a.rows());
    auto l = l_.topLeftCorner(a.rows(), a.rows());
    l = a;
    if (!factorize_lower(l)) return false;
    l.triangularView<Eigen::StrictlyUpper>().setZero();
    n_ = a.rows();
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

namespace {

// C += alpha · A · op(B) on Eigen blocks through the instruction-set-specific kernel
// (simd_kernels.cpp); B(p, j) = b[p·step_p + j·step_j].
template <typename C, typename A>
void gemm(C&& c, double alpha, const A& a, const double* b, Eigen::Index step_p,
          Eigen::Index step_j) {
    detail::gemm_update(c.rows(), c.cols(), a.cols(), alpha, a.data(), a.outerStride(), b,
                        step_p, step_j, c.data(), c.outerStride());
}

constexpr Eigen::Index kBlock = 128;  // blocks of the factorization and of the inverse's product

// Square blocks of `size` covering [0, n); the last one may be narrower.
struct Tiles {
    Eigen::Index n, size;
    int count() const { return static_cast<int>((n + size - 1) / size); }
    Eigen::Index start(int b) const { return static_cast<Eigen::Index>(b) * size; }
    Eigen::Index width(int b) const { return std::min(size, n - start(b)); }
};

}  // namespace

void inverse_from_lower(const Eigen::Ref<const Eigen::MatrixXd>& l, Eigen::MatrixXd& upper_inv,
                        Eigen::MatrixXd& inverse, int threads) {
    // A⁻¹ = U Uᵀ with U = L⁻ᵀ upper triangular. In blocks that skip their zeros this takes ~n³/3
    // multiply-adds instead of the ~n³ of dense solves and a dense product; nearly all of it is
    // gemm_update (fused multiply-adds where the CPU has them: ~2× Eigen's SSE2 products and
    // ~4× its triangular solves here, BENCHMARKS.md). The block size depends on n only, never
    // on threads. Up to kSmallDense one thread and the column-panel kernel (no block overheads).
    const Eigen::Index n = l.rows();
    upper_inv.resize(n, n);
    inverse.resize(n, n);
    if (n <= kSmallDense) {
        detail::inverse_from_lower_small(l.data(), l.outerStride(), n, upper_inv.data(), inverse.data());
        return;
    }
    const Eigen::Index block = kBlock;
    const Tiles grid{n, block};
    const int tiles = grid.count();
    auto start = [&](int b) { return grid.start(b); };
    auto width = [&](int b) { return grid.width(b); };
    // X = L⁻¹, held in `inverse` for now. Its diagonal blocks X(R, R) = L(R, R)⁻¹ first; then
    // by block columns C (independent): X(R, C) = −X(R, R) Σ_{C ≤ K < R} L(R, K) X(K, C) going
    // down. A column's work falls with C; dealt in a snake order (0 1 | 3 2 | 4 5 … for two
    // threads) the threads get equal shares.
    inverse.setZero(n, n);
    parallel_for(tiles, threads, [&](int r) {
        auto diag = inverse.block(start(r), start(r), width(r), width(r));
        diag.setIdentity();
        l.block(start(r), start(r), width(r), width(r)).triangularView<Eigen::Lower>().solveInPlace(diag);
    });
    const int used = std::max(1, std::min(threads, tiles));
    std::vector<int> order(static_cast<std::size_t>(tiles));
    for (int t = 0; t < tiles; ++t) {
        const int round = t / used, slot = t % used;
        const int mirrored = round * used + (used - 1 - slot);
        order[static_cast<std::size_t>(t)] = round % 2 == 0 || mirrored >= tiles ? t : mirrored;
    }
    parallel_for(tiles, used, [&](int t) {
        const int c = order[static_cast<std::size_t>(t)];
        const Eigen::Index c0 = start(c), cw = width(c);
        Eigen::MatrixXd sum(block, cw);
        for (int r = c + 1; r < tiles; ++r) {
            const Eigen::Index r0 = start(r), rw = width(r);
            auto partial = sum.topRows(rw);
            partial.setZero();
            gemm(partial, -1.0, l.block(r0, c0, rw, r0 - c0), &inverse(c0, c0), 1, n);
            auto out = inverse.block(r0, c0, rw, cw);
            gemm(out, 1.0, inverse.block(r0, r0, rw, rw), partial.data(), 1, partial.outerStride());
        }
    });
    parallel_for(tiles, threads, [&](int c) {
        upper_inv.middleCols(start(c), width(c)) = inverse.middleRows(start(c), width(c)).transpose();
    });
    // Lower blocks (R, C), R ≥ C, of A⁻¹: the sum over k from R's first row of U(R, k) U(C, k)ᵀ
    // (U(R, k) = 0 before), each block one task, dealt round-robin (their work shrinks with R).
    std::vector<std::pair<int, int>> targets;
    for (int r = 0; r < tiles; ++r) {
        for (int c = 0; c <= r; ++c) targets.emplace_back(r, c);
    }
    parallel_for(static_cast<int>(targets.size()), threads, [&](int t) {
        const auto [r, c] = targets[static_cast<std::size_t>(t)];
        const Eigen::Index r0 = start(r), c0 = start(c);
        auto out = inverse.block(r0, c0, width(r), width(c));
        out.setZero();
        gemm(out, 1.0, upper_inv.block(r0, r0, width(r), n - r0), &upper_inv(c0, r0), n, 1);
    });
    // The upper triangle by symmetry, one block column per task.
    parallel_for(tiles, threads, [&](int c) {
        const Eigen::Index c0 = start(c), cw = width(c);
        for (int r = 0; r < c; ++r) {
            inverse.block(start(r), c0, width(r), cw) =
                inverse.block(c0, start(r), cw, width(r)).transpose();
        }
        for (Eigen::Index j = 1; j < cw; ++j) {
            inverse.col(c0 + j).segment(c0, j) = inverse.row(c0 + j).segment(c0, j).transpose();
        }
    });
}

bool factorize_lower(Eigen::Ref<Eigen::MatrixXd> a, int threads) {
    const Eigen::Index n = a.rows();
    // The algorithm depends on n only (never on threads), so every thread count gives the same
    // bits. Up to kSmallDense the column-panel kernel: 2× Eigen's LLT at n = 100 (BENCHMARKS.md).
    if (n <= kSmallDense) return detail::cholesky_lower_small(a.data(), n, a.outerStride());
    const Tiles grid{n, kBlock};
    const int blocks = grid.count();
    auto start = [&](int b) { return grid.start(b); };
    auto width = [&](int b) { return grid.width(b); };
    const Eigen::Index ld = a.outerStride();
    for (int k = 0; k < blocks; ++k) {
        const Eigen::Index k0 = start(k);
        const Eigen::Index kw = width(k);
        auto diag = a.block(k0, k0, kw, kw);
        Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(diag);
        if (llt.info() != Eigen::Success) return false;
        const int below = blocks - k - 1;
        if (below == 0) break;
        // Panel: A(i, k) ← A(i, k) L(k, k)⁻ᵀ, one row block per task.
        parallel_for(below, threads, [&](int t) {
            const int i = k + 1 + t;
            auto panel = a.block(start(i), k0, width(i), kw);
            a.block(k0, k0, kw, kw)
                .triangularView<Eigen::Lower>()
                .transpose()
                .solveInPlace<Eigen::OnTheRight>(panel);
        });
        // Trailing update of the lower triangle: A(i, j) −= A(i, k) A(j, k)ᵀ for k < j ≤ i,
        // dealt round-robin (rows differ in length). A diagonal block goes in column strips
        // from the diagonal down (the strict upper triangle is scratch).
        std::vector<std::pair<int, int>> targets;
        for (int i = k + 1; i < blocks; ++i) {
            for (int j = k + 1; j <= i; ++j) targets.emplace_back(i, j);
        }
        parallel_for(static_cast<int>(targets.size()), threads, [&](int t) {
            const auto [i, j] = targets[static_cast<std::size_t>(t)];
            const Eigen::Index i0 = start(i), j0 = start(j);
            if (i != j) {
                gemm(a.block(i0, j0, width(i), width(j)), -1.0, a.block(i0, k0, width(i), kw),
                     &a(j0, k0), ld, 1);
                return;
            }
            constexpr Eigen::Index kStrip = 32;
            for (Eigen::Index s = 0; s < width(i); s += kStrip) {
                const Eigen::Index sw = std::min(kStrip, width(i) - s);
                gemm(a.block(i0 + s, i0 + s, width(i) - s, sw), -1.0,
                     a.block(i0 + s, k0, width(i) - s, kw), &a(i0 + s, k0), ld, 1);
            }
        });
    }
    return true;
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
