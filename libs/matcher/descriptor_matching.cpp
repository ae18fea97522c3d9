#include "matcher/descriptor_matching.hpp"

#include <algorithm>
#include <cmath>

namespace maptune::matcher {
namespace {

// Keeps the n best (largest score, then smallest index) candidates in a small sorted array;
// n <= 10 so insertion beats any heap.
class TopN {
  public:
    void reset(int n) {
        n_ = n;
        size_ = 0;
    }
    float worst() const { return size_ < n_ ? -2.0f : score_[size_ - 1]; }
    void push(float score, int index) {
        if (size_ == n_ && !better(score, index, score_[size_ - 1], index_[size_ - 1])) return;
        int pos = size_ < n_ ? size_++ : size_ - 1;
        while (pos > 0 && better(score, index, score_[pos - 1], index_[pos - 1])) {
            score_[pos] = score_[pos - 1];
            index_[pos] = index_[pos - 1];
            --pos;
        }
        score_[pos] = score;
        index_[pos] = index;
    }
    int size() const { return size_; }
    float score(int i) const { return score_[i]; }
    int index(int i) const { return index_[i]; }

  private:
    static bool better(float s, int i, float s2, int i2) { return s > s2 || (s == s2 && i < i2); }
    static constexpr int kMax = 16;
    float score_[kMax] = {};
    int index_[kMax] = {};
    int n_ = 0;
    int size_ = 0;
};

float dot_to_distance(float dot) { return std::sqrt(std::max(0.0f, 1.0f - dot)); }

void dedup(std::vector<Correspondence>& c) {
    std::sort(c.begin(), c.end(), [](const Correspondence& l, const Correspondence& r) {
        return l.a != r.a ? l.a < r.a : l.b < r.b;
    });
    c.erase(std::unique(c.begin(), c.end(),
                        [](const Correspondence& l, const Correspondence& r) {
                            return l.a == r.a && l.b == r.b;
                        }),
            c.end());
}

}  // namespace

std::vector<Correspondence> match_descriptors(const DescriptorMatrix& A, const DescriptorMatrix& B,
                                              int n_c, double t_c, int block_rows) {
    std::vector<Correspondence> out;
    const int na = static_cast<int>(A.rows()), nb = static_cast<int>(B.rows());
    if (na == 0 || nb == 0 || n_c <= 0 || A.cols() != B.cols() || !(t_c > 0)) return out;
    n_c = std::min(n_c, 16);
    // d < t_c  <=>  dot > 1 - t_c^2 (d is monotone in the dot product).
    const float min_dot = static_cast<float>(1.0 - std::min(1.0, t_c) * std::min(1.0, t_c));
    const bool all_pass = t_c > 1.0;  // every pair qualifies (d <= 1)
    std::vector<TopN> col_best(static_cast<std::size_t>(nb));
    for (auto& t : col_best) t.reset(n_c);
    // Contiguous copy of each column's current worst kept score: the hot loop rejects almost
    // every entry by one compare against it without touching the TopN arrays.
    std::vector<float> col_worst(static_cast<std::size_t>(nb), -2.0f);
    TopN row_best;
    block_rows = std::max(1, block_rows);
    Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> S;
    for (int r0 = 0; r0 < na; r0 += block_rows) {
        const int rows = std::min(block_rows, na - r0);
        S.noalias() = A.middleRows(r0, rows) * B.transpose();
        for (int i = 0; i < rows; ++i) {
            row_best.reset(n_c);
            const float* s = S.data() + static_cast<std::ptrdiff_t>(i) * nb;
            float row_worst = -2.0f;
            const float floor_dot = all_pass ? -2.0f : min_dot;
            for (int j = 0; j < nb; ++j) {
                const float v = s[j];
                if (!(v > floor_dot)) continue;
                // >= keeps tie semantics (smaller index wins) inside TopN::push.
                if (v >= row_worst) {
                    row_best.push(v, j);
                    row_worst = row_best.worst();
                }
                if (v >= col_worst[static_cast<std::size_t>(j)]) {
                    auto& cb = col_best[static_cast<std::size_t>(j)];
                    cb.push(v, r0 + i);
                    col_worst[static_cast<std::size_t>(j)] = cb.worst();
                }
            }
            for (int k = 0; k < row_best.size(); ++k)
                out.push_back({r0 + i, row_best.index(k), dot_to_distance(row_best.score(k))});
        }
    }
    for (int j = 0; j < nb; ++j)
        for (int k = 0; k < col_best[j].size(); ++k)
            out.push_back({col_best[j].index(k), j, dot_to_distance(col_best[j].score(k))});
    dedup(out);
    return out;
}

std::vector<Correspondence> match_descriptors_brute_force(const DescriptorMatrix& A,
                                                          const DescriptorMatrix& B, int n_c,
                                                          double t_c) {
    std::vector<Correspondence> out;
    const int na = static_cast<int>(A.rows()), nb = static_cast<int>(B.rows());
    if (na == 0 || nb == 0 || n_c <= 0 || A.cols() != B.cols() || !(t_c > 0)) return out;
    Eigen::MatrixXd D(na, nb);
    for (int i = 0; i < na; ++i)
        for (int j = 0; j < nb; ++j)
            D(i, j) = (A.row(i).cast<double>() - B.row(j).cast<double>()).norm() / std::sqrt(2.0);
    auto take = [&](int count, auto dist, auto emit) {
        std::vector<int> idx(static_cast<std::size_t>(count));
        for (int k = 0; k < count; ++k) idx[static_cast<std::size_t>(k)] = k;
        std::stable_sort(idx.begin(), idx.end(), [&](int l, int r) { return dist(l) < dist(r); });
        for (int k = 0; k < std::min(n_c, count); ++k) {
            const int m = idx[static_cast<std::size_t>(k)];
            if (dist(m) < t_c) emit(m, dist(m));
        }
    };
    for (int i = 0; i < na; ++i)
        take(
            nb, [&](int j) { return D(i, j); },
            [&](int j, double d) {
                out.push_back({i, j, static_cast<float>(d)});
            });
    for (int j = 0; j < nb; ++j)
        take(
            na, [&](int i) { return D(i, j); },
            [&](int i, double d) {
                out.push_back({i, j, static_cast<float>(d)});
            });
    dedup(out);
    return out;
}

}  // namespace maptune::matcher
