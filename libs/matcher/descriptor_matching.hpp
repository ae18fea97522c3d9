#pragma once
// Bidirectional descriptor correspondences (SPEC §3 step 7) by blocked float GEMM.
//
// Normalized distance: with unit-length descriptors a, b (CSHOT entries are >= 0, so a.b is in
// [0, 1]), d(a, b) = ||a - b|| / sqrt(2) = sqrt(1 - a.b), which lies in [0, 1]. Nearest
// descriptors are those with the largest dot product, so one GEMM A * B^T gives both
// directions; no k-d tree is needed (in 1344 dimensions it degenerates to a linear scan).

#include <vector>

#include "matcher/features.hpp"

namespace maptune::matcher {

struct Correspondence {
    int a = 0;           // row in A (keypoint of submap a)
    int b = 0;           // row in B
    float distance = 0;  // normalized distance in [0, 1]
};

// The k nearest rows of B for every row of A and the k nearest rows of A for every row of B,
// best first (largest dot product, ties to the smaller index). It depends only on the two
// submaps' descriptors, so it can be cached per pair: the correspondences for any n_c <= k
// and any t_c are a prefix of these lists (select_correspondences), exactly.
struct NeighbourLists {
    static constexpr int kMaxK = 16;
    int k = 0, rows = 0, cols = 0;
    std::vector<int> row_count, col_count;  // entries kept per row of A / per row of B
    std::vector<int> row_index, col_index;  // [rows * k], [cols * k]
    std::vector<float> row_dot, col_dot;
    double compute_s = 0;  // [s] what computing them took (kept with the cached lists)
    std::size_t bytes() const {
        return sizeof(*this) + (row_count.size() + col_count.size()) * sizeof(int) +
               (row_index.size() + col_index.size()) * (sizeof(int) + sizeof(float));
    }
};

// k is capped at NeighbourLists::kMaxK. Entries with a dot product <= min_dot are not kept
// (a speed-up when only one threshold is needed; the default keeps everything).
NeighbourLists nearest_descriptors(const DescriptorMatrix& A, const DescriptorMatrix& B, int k,
                                   float min_dot = -2.0f, int block_rows = 256);

// From the lists: per row its up to n_c first entries with distance < t_c, both directions,
// the union without duplicates, sorted by (a, b). Needs n_c <= lists.k.
std::vector<Correspondence> select_correspondences(const NeighbourLists& lists, int n_c,
                                                   double t_c);

// For each row of A its up to n_c nearest rows of B with distance < t_c, and the same from B
// to A; the union without duplicates, sorted by (a, b). Ties go to the smaller index.
// Rows must be unit length (as SubmapFeatures stores them).
std::vector<Correspondence> match_descriptors(const DescriptorMatrix& A, const DescriptorMatrix& B,
                                              int n_c, double t_c, int block_rows = 256);

// Exhaustive double-precision oracle with the same semantics (tests, bench).
std::vector<Correspondence> match_descriptors_brute_force(const DescriptorMatrix& A,
                                                          const DescriptorMatrix& B, int n_c,
                                                          double t_c);

}  // namespace maptune::matcher
