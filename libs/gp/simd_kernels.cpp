#include "gp/simd_kernels.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace maptune::gp::detail {

namespace {

// GCC/Clang vector extensions: one source for AVX-512 (8 doubles), AVX2 (4) and baseline SSE2
// (2). Register tile of the solve: kRows rows of L against a strip of kVecs vectors of queries,
// kRows·kVecs accumulators: 24 of AVX-512's 32 registers, 12 of AVX2's and SSE2's 16.
#if defined(__AVX512F__)
constexpr int kLanes = 8;
constexpr Index kRows = 8;
#elif defined(__AVX__)
constexpr int kLanes = 4;
constexpr Index kRows = 4;
#else
constexpr int kLanes = 2;
constexpr Index kRows = 4;
#endif
constexpr int kVecs = 3;
constexpr Index kStrip = kVecs * kLanes;
typedef double Vec __attribute__((vector_size(8 * kLanes)));
typedef std::int64_t IVec __attribute__((vector_size(8 * kLanes)));

Vec load(const double* p) {
    Vec v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
void store(double* p, Vec v) { std::memcpy(p, &v, sizeof v); }
Vec splat(double x) { return Vec{} + x; }

Vec sqrt_v(Vec x) {
#if defined(__AVX512F__)
    // The zero-masking form: GCC 12 warns (-Wuninitialized) inside the plain _mm512_sqrt_pd.
    return _mm512_maskz_sqrt_pd(0xFF, x);
#elif defined(__AVX__)
    return _mm256_sqrt_pd(x);
#elif defined(__SSE2__)
    return _mm_sqrt_pd(x);
#else
    for (int i = 0; i < kLanes; ++i) x[i] = std::sqrt(x[i]);
    return x;
#endif
}

// e^x for x ≤ 0: 2^k e^r with k = round(x / ln 2) and |r| ≤ ln 2 / 2, where the Taylor
// polynomial of degree 12 is within 2e-16. Below −708 the result would be subnormal; clamping
// there keeps 2^k a normal number (k ≥ −1022) and changes values by < 1e-307.
Vec exp_nonpositive(Vec x) {
    const double shift = 0x1.8p52;  // adding it rounds to an integer kept in the low bits
    const Vec lowest = splat(-708.0);
    x = x < lowest ? lowest : x;
    const Vec t = x * 1.4426950408889634 + shift;
    const Vec k = t - shift;
    const Vec r = (x - k * 6.93147180369123816490e-01) - k * 1.90821492927058770002e-10;
    Vec p = splat(1.0 / 479001600.0);
    p = p * r + 1.0 / 39916800.0;
    p = p * r + 1.0 / 3628800.0;
    p = p * r + 1.0 / 362880.0;
    p = p * r + 1.0 / 40320.0;
    p = p * r + 1.0 / 5040.0;
    p = p * r + 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    p = p * r + 1.0;
    const IVec shift_bits = (IVec)splat(shift);
    const IVec pow2 = ((IVec)t - shift_bits + 1023) << 52;
    return p * (Vec)pow2;
}

// k and q of matern52_from_sq_dist for one vector of squared distances.
void matern52_terms(Vec r2, double signal_variance, Vec& k, Vec& q) {
    const double sqrt5 = 2.23606797749978969641;
    const Vec s5r = sqrt5 * sqrt_v(r2);
    const Vec se = signal_variance * exp_nonpositive(-s5r);
    k = ((1.0 + s5r) + (5.0 / 3.0) * r2) * se;
    q = (5.0 / 3.0) * (1.0 + s5r) * se;
}

constexpr std::size_t kCacheLine = 64;  // bytes

Index padded(Index n) { return (n + kRows - 1) / kRows * kRows; }
Index min_index(Index a, Index b) { return a < b ? a : b; }
Index block_offset(Index b) { return kRows * kRows * b * (b + 1) / 2; }

// Strip y (n_pad rows of kStrip queries): y[i][c] = k(z_i, zq_c), zero on padding rows;
// mean[c] = Σ_i y[i][c] α_i. zq holds the strip's queries dimension-major (dim × kStrip).
void cross_covariance(const PredictProblem& p, Index n_pad, const double* zq, double* y,
                      double* mean) {
    Vec acc[kVecs] = {};
    for (Index i = 0; i < p.n; ++i) {
        const double* zi = p.z + i * p.dim;
        Vec r2[kVecs] = {};
        for (int d = 0; d < p.dim; ++d) {
            // Differences rather than |a|² + |b|² − 2a·b: no cancellation next to observations.
            for (int v = 0; v < kVecs; ++v) {
                const Vec diff = load(zq + d * kStrip + v * kLanes) - zi[d];
                r2[v] += diff * diff;
            }
        }
        for (int v = 0; v < kVecs; ++v) {
            Vec k, q;
            matern52_terms(r2[v], p.signal_variance, k, q);
            store(y + i * kStrip + v * kLanes, k);
            acc[v] += k * p.alpha[i];
        }
    }
    const auto padding = static_cast<std::size_t>((n_pad - p.n) * kStrip);
    std::memset(y + p.n * kStrip, 0, sizeof(double) * padding);
    for (int v = 0; v < kVecs; ++v) store(mean + v * kLanes, acc[v]);
}

// Rows i0 .. i0 + kRows − 1 of L⁻¹k* for every query of a strip, given the earlier rows
// (left-looking), in place of k*; adds their squares to ss.
void solve_rows(const double* lb, Index i0, const double* inv_diag, double* y, double* ss) {
    Vec a[kRows][kVecs];
    for (Index r = 0; r < kRows; ++r) {
        for (int v = 0; v < kVecs; ++v) a[r][v] = load(y + (i0 + r) * kStrip + v * kLanes);
    }
    for (Index j = 0; j < i0; ++j) {
        const double* yj = y + j * kStrip;
        Vec yv[kVecs];
        for (int v = 0; v < kVecs; ++v) yv[v] = load(yj + v * kLanes);
        const double* l = lb + j * kRows;
        for (Index r = 0; r < kRows; ++r) {
            for (int v = 0; v < kVecs; ++v) a[r][v] -= l[r] * yv[v];
        }
    }
    const double* d = lb + i0 * kRows;  // d[jj·kRows + r] = L(i0 + r, i0 + jj)
    Vec s[kVecs];
    for (int v = 0; v < kVecs; ++v) s[v] = load(ss + v * kLanes);
    for (Index r = 0; r < kRows; ++r) {
        for (Index jj = 0; jj < r; ++jj) {
            for (int v = 0; v < kVecs; ++v) a[r][v] -= d[jj * kRows + r] * a[jj][v];
        }
        for (int v = 0; v < kVecs; ++v) {
            a[r][v] *= inv_diag[i0 + r];
            store(y + (i0 + r) * kStrip + v * kLanes, a[r][v]);
            s[v] += a[r][v] * a[r][v];
        }
    }
    for (int v = 0; v < kVecs; ++v) store(ss + v * kLanes, s[v]);
}

// acc + x·y, fused where the instruction set has it (the ISO C++ build does not contract).
Vec fma_v(Vec x, Vec y, Vec acc) {
#if defined(__AVX512F__)
    return _mm512_fmadd_pd(x, y, acc);
#elif defined(__FMA__)
    return _mm256_fmadd_pd(x, y, acc);
#else
    return acc + x * y;
#endif
}

// One register tile of gemm_update: V vectors of rows × NR columns.
template <int V, int NR>
void gemm_tile(Index k, double alpha, const double* a, Index lda, const double* b, Index sp,
               Index sj, double* c, Index ldc) {
    Vec acc[V][NR] = {};
    for (Index p = 0; p < k; ++p) {
        Vec av[V];
        for (int v = 0; v < V; ++v) av[v] = load(a + p * lda + v * kLanes);
        const double* bp = b + p * sp;
        for (int j = 0; j < NR; ++j) {
            const Vec bj = splat(bp[j * sj]);
            for (int v = 0; v < V; ++v) acc[v][j] = fma_v(av[v], bj, acc[v][j]);
        }
    }
    for (int j = 0; j < NR; ++j) {
        for (int v = 0; v < V; ++v) {
            double* cj = c + j * ldc + v * kLanes;
            store(cj, fma_v(splat(alpha), acc[v][j], load(cj)));
        }
    }
}

// The columns j0 .. j0 + NR − 1 of C for rows [0, m): full tiles, then one vector, then scalars.
template <int NR>
void gemm_columns(Index m, Index k, double alpha, const double* a, Index lda, const double* b,
                  Index sp, Index sj, double* c, Index ldc) {
    Index i = 0;
    for (; i + 2 * kLanes <= m; i += 2 * kLanes) gemm_tile<2, NR>(k, alpha, a + i, lda, b, sp, sj, c + i, ldc);
    for (; i + kLanes <= m; i += kLanes) gemm_tile<1, NR>(k, alpha, a + i, lda, b, sp, sj, c + i, ldc);
    for (; i < m; ++i) {
        for (int j = 0; j < NR; ++j) {
            double acc = 0.0;
            for (Index p = 0; p < k; ++p) acc += a[i + p * lda] * b[p * sp + j * sj];
            c[i + j * ldc] += alpha * acc;
        }
    }
}

}  // namespace

void gemm_update(Index m, Index n, Index k, double alpha, const double* a, Index lda,
                 const double* b, Index b_step_p, Index b_step_j, double* c, Index ldc) {
    constexpr int kCols = 6;
    // Chunks of the inner dimension: A's m × kDepth slice (≤ 256 KB at m = 128) stays in L2
    // while every column tile passes over it, instead of streaming all of A per tile.
    constexpr Index kDepth = 256;
    for (Index p0 = 0; p0 < k; p0 += kDepth) {
        const Index kc = min_index(kDepth, k - p0);
        const double* ap = a + p0 * lda;
        const double* bp = b + p0 * b_step_p;
        Index j = 0;
        for (; j + kCols <= n; j += kCols) {
            gemm_columns<kCols>(m, kc, alpha, ap, lda, bp + j * b_step_j, b_step_p, b_step_j,
                                c + j * ldc, ldc);
        }
        for (; j < n; ++j) {
            gemm_columns<1>(m, kc, alpha, ap, lda, bp + j * b_step_j, b_step_p, b_step_j,
                            c + j * ldc, ldc);
        }
    }
}

void matern52_from_sq_dist(const double* r2, Index count, double signal_variance, double* k,
                           double* q) {
    Index i = 0;
    for (; i + kLanes <= count; i += kLanes) {
        Vec kv, qv;
        matern52_terms(load(r2 + i), signal_variance, kv, qv);
        store(k + i, kv);
        if (q != nullptr) store(q + i, qv);
    }
    if (i < count) {
        // The tail through a zero-padded vector, so that every value takes the same path.
        double in[kLanes] = {}, out_k[kLanes], out_q[kLanes];
        std::memcpy(in, r2 + i, sizeof(double) * static_cast<std::size_t>(count - i));
        Vec kv, qv;
        matern52_terms(load(in), signal_variance, kv, qv);
        store(out_k, kv);
        store(out_q, qv);
        std::memcpy(k + i, out_k, sizeof(double) * static_cast<std::size_t>(count - i));
        if (q != nullptr) {
            std::memcpy(q + i, out_q, sizeof(double) * static_cast<std::size_t>(count - i));
        }
    }
}

void scaled_sq_dist_columns(const double* zt, Index n, int dim, Index c0, Index w, double* r2,
                            Index ld) {
    // Four vectors of rows at a time: four independent sums hide the add latency.
    constexpr Index kGroup = 4 * kLanes;
    const Index grouped = n / kGroup * kGroup;
    const Index full = n / kLanes * kLanes;
    double pad[kLanes], out[kLanes];
    for (Index j = 0; j < w; ++j) {
        const double* zj = zt + c0 + j;
        double* col = r2 + j * ld;
        Index i = 0;
        for (; i < grouped; i += kGroup) {
            Vec a0 = splat(0.0), a1 = a0, a2 = a0, a3 = a0;
            for (int k = 0; k < dim; ++k) {
                const double* zk = zt + static_cast<Index>(k) * n + i;
                const double v = zj[static_cast<Index>(k) * n];
                const Vec d0 = load(zk) - v, d1 = load(zk + kLanes) - v;
                const Vec d2 = load(zk + 2 * kLanes) - v, d3 = load(zk + 3 * kLanes) - v;
                a0 += d0 * d0;
                a1 += d1 * d1;
                a2 += d2 * d2;
                a3 += d3 * d3;
            }
            store(col + i, a0);
            store(col + i + kLanes, a1);
            store(col + i + 2 * kLanes, a2);
            store(col + i + 3 * kLanes, a3);
        }
        for (; i < n; i += kLanes) {
            Vec acc = splat(0.0);
            for (int k = 0; k < dim; ++k) {
                const double* zk = zt + static_cast<Index>(k) * n;
                Vec zi;
                if (i < full) {
                    zi = load(zk + i);
                } else {
                    // The tail through a padded vector: every value takes the same path.
                    for (Index l = 0; l < kLanes; ++l) pad[l] = i + l < n ? zk[i + l] : 0.0;
                    zi = load(pad);
                }
                const Vec dz = zi - zj[static_cast<Index>(k) * n];
                acc += dz * dz;
            }
            if (i < full) {
                store(col + i, acc);
            } else {
                store(out, acc);
                std::memcpy(col + i, out, sizeof(double) * static_cast<std::size_t>(n - i));
            }
        }
    }
}

void weighted_sq_dist_sums(const double* zt, Index n, int dim, Index c0, Index w, const double* m,
                           Index ld, double* out) {
    // Blocks of m small enough for L1 are passed over once per dimension; each block's sum per
    // dimension is added to out in a fixed order (blocks depend on n, c0 and w only).
    constexpr Index kRowBlock = 256, kColBlock = 16;
    constexpr Index kGroup = 4 * kLanes;
    double pad_z[kLanes], pad_m[kLanes], lanes[kLanes];
    for (Index j0 = 0; j0 < w; j0 += kColBlock) {
        const Index jw = min_index(kColBlock, w - j0);
        for (Index i0 = 0; i0 < n; i0 += kRowBlock) {
            const Index i1 = min_index(n, i0 + kRowBlock);
            const Index grouped = i0 + (i1 - i0) / kGroup * kGroup;
            const Index full = i0 + (i1 - i0) / kLanes * kLanes;
            for (int k = 0; k < dim; ++k) {
                const double* zk = zt + static_cast<Index>(k) * n;
                // Four sums hide the add latency.
                Vec a0 = splat(0.0), a1 = a0, a2 = a0, a3 = a0;
                for (Index j = j0; j < j0 + jw; ++j) {
                    const double zj = zk[c0 + j];
                    const double* mj = m + j * ld;
                    Index i = i0;
                    for (; i < grouped; i += kGroup) {
                        const Vec d0 = load(zk + i) - zj, d1 = load(zk + i + kLanes) - zj;
                        const Vec d2 = load(zk + i + 2 * kLanes) - zj;
                        const Vec d3 = load(zk + i + 3 * kLanes) - zj;
                        a0 += load(mj + i) * (d0 * d0);
                        a1 += load(mj + i + kLanes) * (d1 * d1);
                        a2 += load(mj + i + 2 * kLanes) * (d2 * d2);
                        a3 += load(mj + i + 3 * kLanes) * (d3 * d3);
                    }
                    for (; i < full; i += kLanes) {
                        const Vec dz = load(zk + i) - zj;
                        a0 += load(mj + i) * (dz * dz);
                    }
                    if (i < i1) {
                        for (Index l = 0; l < kLanes; ++l) {
                            pad_z[l] = i + l < i1 ? zk[i + l] : zj;
                            pad_m[l] = i + l < i1 ? mj[i + l] : 0.0;
                        }
                        const Vec dz = load(pad_z) - zj;
                        a1 += load(pad_m) * (dz * dz);
                    }
                }
                store(lanes, (a0 + a1) + (a2 + a3));
                double sum = 0.0;
                for (double v : lanes) sum += v;
                out[k] += sum;
            }
        }
    }
}

namespace {

// Panels of kPanel target columns share every vector of x they load (kPanel multiply-adds per
// load): acc[c][v] += Σ_{k0 ≤ k < k1} s[c][k·ss] · x(row + v·kLanes, k), x(i, k) = x[i + k·xs].
constexpr int kPanel = 4;
template <int V>
void panel_sums(const double* const* s, Index ss, const double* x, Index xs, Index k0, Index k1,
                Vec (&acc)[kPanel][V]) {
    for (Index k = k0; k < k1; ++k) {
        const double* xk = x + k * xs;
        Vec xv[V];
        for (int v = 0; v < V; ++v) xv[v] = load(xk + v * kLanes);
        for (int c = 0; c < kPanel; ++c) {
            const double sc = s[c][k * ss];
            for (int v = 0; v < V; ++v) acc[c][v] += sc * xv[v];
        }
    }
}

// For the jb ≤ kPanel columns out[c] (leading dimension implied by the pointers) and rows
// [r_begin, r_end): out[c][row] = (init ? out[c][row] : 0) + sign · Σ_k s[c][k·ss] x(row, k), with
// k from k_first(row block start) to k_end. Row blocks of two vectors, then one, then single
// rows; every row block's sum runs over k in the same order.
template <typename KFirst>
void panel_rows(double* const* out, int jb, const double* const* s, Index ss, const double* x,
                Index xs, Index r_begin, Index r_end, KFirst k_first, Index k_end, bool init,
                double sign) {
    Index r = r_begin;
    for (; r + 2 * kLanes <= r_end; r += 2 * kLanes) {
        Vec acc[kPanel][2] = {};
        panel_sums<2>(s, ss, x + r, xs, k_first(r), k_end, acc);
        for (int c = 0; c < jb; ++c) {
            for (int v = 0; v < 2; ++v) {
                double* o = out[c] + r + v * kLanes;
                store(o, (init ? load(o) : splat(0.0)) + sign * acc[c][v]);
            }
        }
    }
    for (; r + kLanes <= r_end; r += kLanes) {
        Vec acc[kPanel][1] = {};
        panel_sums<1>(s, ss, x + r, xs, k_first(r), k_end, acc);
        for (int c = 0; c < jb; ++c) {
            double* o = out[c] + r;
            store(o, (init ? load(o) : splat(0.0)) + sign * acc[c][0]);
        }
    }
    for (; r < r_end; ++r) {
        for (int c = 0; c < jb; ++c) {
            double v = 0.0;
            for (Index k = k_first(r); k < k_end; ++k) v += s[c][k * ss] * x[r + k * xs];
            out[c][r] = (init ? out[c][r] : 0.0) + sign * v;
        }
    }
}

// The pointers of a panel's columns j = j0 + c (c < kPanel; past jb the last one again, whose
// sums are then not stored): out[c] = out_base + j·out_ld, s[c] = s_base + j.
void panel_pointers(double* out_base, Index out_ld, const double* s_base, Index j0, int jb,
                    double* (&out)[kPanel], const double* (&s)[kPanel]) {
    for (int c = 0; c < kPanel; ++c) {
        const Index j = j0 + min_index(c, jb - 1);
        out[c] = out_base + j * out_ld;
        s[c] = s_base + j;
    }
}

}  // namespace

bool cholesky_lower_small(double* a, Index n, Index ld) {
    // Left-looking in panels of kPanel columns: first every panel column's rows j0.. minus the
    // columns left of the panel (shared loads), then the panel's own columns one by one.
    for (Index j0 = 0; j0 < n; j0 += kPanel) {
        const int jb = static_cast<int>(min_index(kPanel, n - j0));
        double* out[kPanel];
        const double* s[kPanel];
        panel_pointers(a, ld, a, j0, jb, out, s);  // s[c][k·ld] = L(j, k)
        panel_rows(out, jb, s, ld, a, ld, j0, n, [](Index) { return Index{0}; }, j0, true, -1.0);
        for (int c = 0; c < jb; ++c) {
            const Index j = j0 + c;
            double* cj = a + j * ld;
            for (Index k = j0; k < j; ++k) {
                const double ljk = a[j + k * ld];
                const double* ck = a + k * ld;
                for (Index i = j; i < n; ++i) cj[i] -= ljk * ck[i];
            }
            const double d = cj[j];
            if (!(d > 0.0)) return false;  // also NaN
            const double root = std::sqrt(d);
            cj[j] = root;
            const double inv = 1.0 / root;
            for (Index i = j + 1; i < n; ++i) cj[i] *= inv;
        }
    }
    return true;
}

void inverse_from_lower_small(const double* l, Index ld, Index n, double* u, double* inv) {
    std::memset(u, 0, sizeof(double) * static_cast<std::size_t>(n * n));
    // U = L⁻ᵀ by columns: U(r, i) = −U(i, i) Σ_{r ≤ k < i} L(i, k) U(r, k), U(i, i) = 1 / L(i, i).
    // A block of rows starting at r needs only k ≥ r (U is zero below its diagonal). In panels:
    // the sums over the columns left of the panel first (shared loads), then the panel's own.
    for (Index i0 = 0; i0 < n; i0 += kPanel) {
        const int jb = static_cast<int>(min_index(kPanel, n - i0));
        double* out[kPanel];
        const double* s[kPanel];
        panel_pointers(u, n, l, i0, jb, out, s);  // s[c][k·ld] = L(i, k)
        panel_rows(out, jb, s, ld, u, n, 0, i0, [](Index r) { return r; }, i0, false, 1.0);
        for (int c = 0; c < jb; ++c) {
            const Index i = i0 + c;
            double* ui = u + i * n;
            for (Index k = i0; k < i; ++k) {
                const double lik = l[i + k * ld];
                const double* uk = u + k * n;
                for (Index r = 0; r <= k; ++r) ui[r] += lik * uk[r];
            }
            const double uii = 1.0 / l[i + i * ld];
            for (Index r = 0; r < i; ++r) ui[r] *= -uii;
            ui[i] = uii;
        }
    }
    // Lower triangle of U Uᵀ: inv(i, j) = Σ_{k ≥ i} U(i, k) U(j, k); a block of rows starting at
    // r needs only k ≥ r. A panel's later columns also fill a few rows above their diagonal
    // (U(j, k) = 0 for k < j makes them exact too); the upper triangle is then set by symmetry.
    for (Index j0 = 0; j0 < n; j0 += kPanel) {
        const int jb = static_cast<int>(min_index(kPanel, n - j0));
        double* out[kPanel];
        const double* s[kPanel];
        panel_pointers(inv, n, u, j0, jb, out, s);  // s[c][k·n] = U(j, k)
        panel_rows(out, jb, s, n, u, n, j0, n, [](Index r) { return r; }, n, false, 1.0);
    }
    for (Index j = 0; j < n; ++j) {
        for (Index i = j + 1; i < n; ++i) inv[j + i * n] = inv[i + j * n];
    }
}

Index strip_width() { return kStrip; }

const char* instruction_set() {
#if defined(__AVX512F__)
    return "avx512";
#elif defined(__AVX2__) && defined(__FMA__)
    return "avx2";
#elif defined(__SSE2__)
    return "sse2";
#else
    return "generic";
#endif
}

Index packed_lower_size(Index n) {
    const Index n_pad = padded(n);
    return block_offset(n_pad / kRows) + n_pad;
}

void pack_lower(const double* l, Index ld, Index n, double* packed) {
    // Block b holds rows i0 = b·kRows .. i0 + kRows − 1 for columns 0 .. i0 + kRows − 1,
    // column by column (the kRows values of a column are adjacent), zero above the diagonal.
    // Padding rows are rows of the identity, so their solution is 0 and adds nothing.
    const Index n_pad = padded(n);
    const Index blocks = n_pad / kRows;
    double* inv_diag = packed + block_offset(blocks);
    for (Index b = 0; b < blocks; ++b) {
        const Index i0 = b * kRows;
        double* lb = packed + block_offset(b);
        for (Index j = 0; j < i0 + kRows; ++j) {
            for (Index r = 0; r < kRows; ++r) {
                const Index i = i0 + r;
                double value = 0.0;
                if (i < n) {
                    if (j <= i) value = l[j * ld + i];
                } else if (j == i) {
                    value = 1.0;
                }
                lb[j * kRows + r] = value;
            }
        }
    }
    for (Index i = 0; i < n_pad; ++i) inv_diag[i] = i < n ? 1.0 / l[i * ld + i] : 1.0;
}

Index work_size(Index n, int dim, Index strips) {
    return strips * kStrip * (padded(n) + 2) + dim * kStrip +
           static_cast<Index>(kCacheLine / sizeof(double));
}

void predict_range(const PredictProblem& p, const double* zs, Index first, Index count,
                   Index strips, double* work, double* mean, double* variance) {
    const Index n_pad = padded(p.n);
    const Index blocks = n_pad / kRows;
    const double* inv_diag = p.packed_l + block_offset(blocks);
    const Index y_size = n_pad * kStrip;
    // Strips start on a cache line: with AVX-512 a strip row is three lines, so no 512-bit
    // load of the solve's inner loop straddles two (malloc gives 16-byte alignment).
    while (reinterpret_cast<std::uintptr_t>(work) % kCacheLine != 0) ++work;
    double* ys = work;                     // strips × n_pad × kStrip
    double* ss = ys + strips * y_size;     // strips × kStrip
    double* means = ss + strips * kStrip;  // strips × kStrip
    double* zq = means + strips * kStrip;  // dim × kStrip, one strip at a time
    for (Index done = 0; done < count; done += strips * kStrip) {
        const Index chunk = min_index(strips * kStrip, count - done);
        const Index chunk_strips = (chunk + kStrip - 1) / kStrip;
        for (Index s = 0; s < chunk_strips; ++s) {
            for (Index c = 0; c < kStrip; ++c) {
                // A partial strip repeats its last query; those lanes are discarded.
                const Index q = first + done + min_index(s * kStrip + c, chunk - 1);
                for (int d = 0; d < p.dim; ++d) zq[d * kStrip + c] = zs[q * p.dim + d];
            }
            cross_covariance(p, n_pad, zq, ys + s * y_size, means + s * kStrip);
            std::memset(ss + s * kStrip, 0, sizeof(double) * kStrip);
        }
        // Row blocks outside, strips inside: a block of L (kRows·n doubles) stays in cache
        // while every strip of the chunk streams its earlier rows from L2.
        for (Index b = 0; b < blocks; ++b) {
            const double* lb = p.packed_l + block_offset(b);
            for (Index s = 0; s < chunk_strips; ++s) {
                solve_rows(lb, b * kRows, inv_diag, ys + s * y_size, ss + s * kStrip);
            }
        }
        for (Index c = 0; c < chunk; ++c) {
            mean[done + c] = means[c];
            variance[done + c] = p.signal_variance - ss[c];
        }
    }
}

}  // namespace maptune::gp::detail
