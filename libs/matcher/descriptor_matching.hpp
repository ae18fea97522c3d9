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
