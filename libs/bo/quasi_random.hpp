#pragma once
// Scrambled Halton sequence: low-discrepancy points in [0, 1)^d for the initial design and
// for acquisition candidates. Random digit permutations (seeded) break the correlation of
// plain Halton between high-index primes.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace maptune::bo {

class ScrambledHalton {
  public:
    ScrambledHalton(int dim, std::uint64_t seed);
    Eigen::VectorXd point(std::uint64_t index) const;
    // Columns index, index+1, ..., index+n-1 as a d×n matrix.
    Eigen::MatrixXd points(std::uint64_t index, Eigen::Index n) const;

  private:
    int dim_;
    std::vector<int> bases_;
    std::vector<int> digits_;                           // digits used per dimension
    std::vector<std::vector<std::vector<int>>> perms_;  // [dim][digit] -> permutation
};

}  // namespace maptune::bo
