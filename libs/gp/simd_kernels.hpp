#pragma once
// The GP's hot loops, in double (internal to libs/gp): elementwise Matern-5/2 for kernel
// matrices and the fit, and the O(n²m) core of GaussianProcess::predict (cross-covariances,
// K*ᵀα and the column norms of L⁻¹K*, blocked for registers and cache).
//
// Plain arrays only: simd_kernels.cpp may be compiled with AVX2/FMA or AVX-512 while the rest of
// the library is not, so no Eigen or other template code may cross this boundary (Eigen's aligned
// allocator and its kernels differ between the two instruction sets, and the linker keeps one
// copy of each inline function).

#include <cstddef>

namespace maptune::gp::detail {

using Index = std::ptrdiff_t;

// Elementwise over count values: k = s²(1 + √5 r + 5r²/3) e^{−√5 r} from r2 = r², and, when
// q is not null, q = s² (5/3)(1 + √5 r) e^{−√5 r} (the fit's length-scale gradient:
// dk/dlog ℓ_j = q · (scaled distance in dimension j)²). Within 3e-16 relative of exact.
void matern52_from_sq_dist(const double* r2, Index count, double signal_variance, double* k,
                           double* q);

// The fit's O(n²d) terms, on zt: n×dim column-major inputs divided by the length scales
// (zt[i + k·n] = dimension k of point i), for the columns c0 .. c0 + w − 1 of n×n matrices
// stored column-major with leading dimension ld. Every element is computed the same way
// whatever c0 and w are (so slabs on any number of threads give the same bits).
// r2(i, j) = Σ_k (zt(i, k) − zt(c0 + j, k))²: exact differences, zero on the diagonal.
void scaled_sq_dist_columns(const double* zt, Index n, int dim, Index c0, Index w, double* r2,
                            Index ld);
// out[k] += Σ_j Σ_i m(i, j) (zt(i, k) − zt(c0 + j, k))² for every dimension k: with m = W ∘ Q
// the length-scale part of the log marginal likelihood's gradient.
void weighted_sq_dist_sums(const double* zt, Index n, int dim, Index c0, Index w, const double* m,
                           Index ld, double* out);

// Small dense factorization and inverse (n up to a few hundred: the matrix stays in L2), as
// sums of columns held in registers. The lower Cholesky factor of a (n×n, column-major, leading
// dimension ld; the lower triangle is the input and receives L, a few entries just above the
// diagonal serve as scratch) in place, left-looking by columns; false if a is not positive
// definite.
bool cholesky_lower_small(double* a, Index n, Index ld);
// From the lower factor l (leading dimension ld): u = L⁻ᵀ (upper triangular, zero below, n×n
// with leading dimension n) and inv = A⁻¹ = u uᵀ (n×n, leading dimension n, exactly symmetric).
// n³/3 multiply-adds.
void inverse_from_lower_small(const double* l, Index ld, Index n, double* u, double* inv);

// Query points per strip (the register tile's width): 24 with AVX-512, 12 with AVX2, 6 without.
Index strip_width();
// What simd_kernels.cpp was compiled for: "avx512", "avx2", "sse2" or "generic".
const char* instruction_set();

// L (n×n lower, column-major, leading dimension ld) in the row-block layout predict_range
// reads; packed must hold packed_lower_size(n) doubles.
Index packed_lower_size(Index n);
void pack_lower(const double* l, Index ld, Index n, double* packed);

struct PredictProblem {
    Index n = 0;  // observations
    int dim = 0;
    const double* z = nullptr;         // dim×n inputs divided by the length scales, column-major
    const double* alpha = nullptr;     // K⁻¹y, n values (standardized units)
    const double* packed_l = nullptr;  // pack_lower(L) of K + noise + jitter = L Lᵀ
    double signal_variance = 1.0;
};

// Doubles of work space predict_range needs to process `strips` strips at a time.
Index work_size(Index n, int dim, Index strips);
// Mean K*ᵀα and latent variance s² − ‖L⁻¹k*‖² (standardized units, not clamped) of the
// queries zs.col(first) .. zs.col(first + count − 1); zs is dim×m column-major and scaled like
// z. Processes `strips` strips at a time in work (work_size(n, dim, strips) doubles). Every query's
// result depends only on that query, never on first, count or strips.
void predict_range(const PredictProblem& p, const double* zs, Index first, Index count,
                   Index strips, double* work, double* mean, double* variance);

// C += alpha · A · B for column-major A (m×k, leading dimension lda) and C (m×n, ldc), where
// B(p, j) = b[p·b_step_p + j·b_step_j] (so B can be a transpose without a copy). The dense
// core of the blocked Cholesky factorization and inverse (cholesky.cpp); register tiles of
// 2 vectors × 6 columns with fused multiply-adds where the instruction set has them. The
// result depends on the operands only (fixed summation order over p).
void gemm_update(Index m, Index n, Index k, double alpha, const double* a, Index lda,
                 const double* b, Index b_step_p, Index b_step_j, double* c, Index ldc);

}  // namespace maptune::gp::detail
