#include "bo/quasi_random.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace maptune::bo {

namespace {
std::vector<int> first_primes(int count) {
    std::vector<int> primes;
    for (int c = 2; static_cast<int>(primes.size()) < count; ++c) {
        bool prime = true;
        for (int p : primes) {
            if (p * p > c) break;
            if (c % p == 0) {
                prime = false;
                break;
            }
        }
        if (prime) primes.push_back(c);
    }
    return primes;
}
}  // namespace

ScrambledHalton::ScrambledHalton(int dim, std::uint64_t seed)
    : dim_(dim), bases_(first_primes(dim)), digits_(static_cast<std::size_t>(dim)) {
    std::mt19937_64 rng(seed);
    perms_.resize(static_cast<std::size_t>(dim));
    for (int j = 0; j < dim; ++j) {
        const int b = bases_[static_cast<std::size_t>(j)];
        // Enough digits for double resolution.
        const int k = static_cast<int>(std::ceil(53.0 * std::log(2.0) / std::log(b)));
        digits_[static_cast<std::size_t>(j)] = k;
        auto& pj = perms_[static_cast<std::size_t>(j)];
        pj.resize(static_cast<std::size_t>(k));
        for (auto& perm : pj) {
            perm.resize(static_cast<std::size_t>(b));
            std::iota(perm.begin(), perm.end(), 0);
            for (int i = b - 1; i > 0; --i) {
                std::uniform_int_distribution<int> pick(0, i);
                std::swap(perm[static_cast<std::size_t>(i)],
                          perm[static_cast<std::size_t>(pick(rng))]);
            }
        }
    }
}

Eigen::VectorXd ScrambledHalton::point(std::uint64_t index) const {
    Eigen::VectorXd p(dim_);
    for (int j = 0; j < dim_; ++j) {
        const auto b = static_cast<std::uint64_t>(bases_[static_cast<std::size_t>(j)]);
        const auto& pj = perms_[static_cast<std::size_t>(j)];
        double value = 0.0;
        double scale = 1.0 / static_cast<double>(b);
        std::uint64_t i = index;
        for (int k = 0; k < digits_[static_cast<std::size_t>(j)]; ++k) {
            const auto digit = static_cast<std::size_t>(i % b);
            value += pj[static_cast<std::size_t>(k)][digit] * scale;
            i /= b;
            scale /= static_cast<double>(b);
        }
        p(j) = std::min(value, std::nextafter(1.0, 0.0));
    }
    return p;
}

Eigen::MatrixXd ScrambledHalton::points(std::uint64_t index, Eigen::Index n) const {
    Eigen::MatrixXd out(dim_, n);
    for (Eigen::Index i = 0; i < n; ++i) out.col(i) = point(index + static_cast<std::uint64_t>(i));
    return out;
}

}  // namespace maptune::bo
