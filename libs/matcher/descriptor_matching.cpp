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

NeighbourLists nearest_descriptors(const DescriptorMatrix& A, const DescriptorMatrix& B, int k,
                                   float min_dot, int block_rows) {
    NeighbourLists L;
    const int na = static_cast<int>(A.rows()), nb = static_cast<int>(B.rows());
    L.k = std::clamp(k, 0, NeighbourLists::kMaxK);
    if (na == 0 || nb == 0 || L.k == 0 || A.cols() != B.cols()) return L;
    L.rows = na;
    L.cols = nb;
    L.row_count.assign(static_cast<std::size_t>(na), 0);
    L.row_index.assign(static_cast<std::size_t>(na) * L.k, 0);
    L.row_dot.assign(static_cast<std::size_t>(na) * L.k, 0.f);
    std::vector<TopN> col_best(static_cast<std::size_t>(nb));
    for (auto& t : col_best) t.reset(L.k);
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
            row_best.reset(L.k);
            const float* s = S.data() + static_cast<std::ptrdiff_t>(i) * nb;
            float row_worst = -2.0f;
            for (int j = 0; j < nb; ++j) {
                const float v = s[j];
                if (!(v > min_dot)) continue;
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
            const std::size_t base = static_cast<std::size_t>(r0 + i) * L.k;
            L.row_count[static_cast<std::size_t>(r0 + i)] = row_best.size();
            for (int q = 0; q < row_best.size(); ++q) {
                L.row_index[base + q] = row_best.index(q);
                L.row_dot[base + q] = row_best.score(q);
            }
        }
    }
    L.col_count.assign(static_cast<std::size_t>(nb), 0);
    L.col_index.assign(static_cast<std::size_t>(nb) * L.k, 0);
    L.col_dot.assign(static_cast<std::size_t>(nb) * L.k, 0.f);
    for (int j = 0; j < nb; ++j) {
        const auto& cb = col_best[static_cast<std::size_t>(j)];
        const std::size_t base = static_cast<std::size_t>(j) * L.k;
        L.col_count[static_cast<std::size_t>(j)] = cb.size();
        for (int q = 0; q < cb.size(); ++q) {
            L.col_index[base + q] = cb.index(q);
            L.col_dot[base + q] = cb.score(q);
        }
    }
    return L;
}

std::vector<Correspondence> select_correspondences(const NeighbourLists& L, int n_c, double t_c) {
    std::vector<Correspondence> out;
    if (n_c <= 0 || !(t_c > 0)) return out;
    n_c = std::min(n_c, L.k);
    // d < t_c  <=>  dot > 1 - t_c^2 (d is monotone in the dot product); t_c > 1 passes all.
    const bool all_pass = t_c > 1.0;
    const float min_dot = static_cast<float>(1.0 - std::min(1.0, t_c) * std::min(1.0, t_c));
    auto take = [&](int n, const std::vector<int>& count, const std::vector<int>& index,
                    const std::vector<float>& dot, bool rows) {
        for (int i = 0; i < n; ++i) {
            const std::size_t base = static_cast<std::size_t>(i) * L.k;
            const int m = std::min(n_c, count[static_cast<std::size_t>(i)]);
            for (int q = 0; q < m; ++q) {
                const float v = dot[base + q];
                if (!all_pass && !(v > min_dot)) break;  // lists are best first
                const int other = index[base + q];
                out.push_back({rows ? i : other, rows ? other : i, dot_to_distance(v)});
            }
        }
    };
    take(L.rows, L.row_count, L.row_index, L.row_dot, true);
    take(L.cols, L.col_count, L.col_index, L.col_dot, false);
    dedup(out);
    return out;
}

std::vector<Correspondence> match_descriptors(const DescriptorMatrix& A, const DescriptorMatrix& B,
                                              int n_c, double t_c, int block_rows) {
    if (n_c <= 0 || !(t_c > 0)) return {};
    n_c = std::min(n_c, NeighbourLists::kMaxK);
    // Only one threshold is needed here: entries that cannot pass it are never kept.
    const float min_dot =
        t_c > 1.0 ? -2.0f : static_cast<float>(1.0 - std::min(1.0, t_c) * std::min(1.0, t_c));
    return select_correspondences(nearest_descriptors(A, B, n_c, min_dot, block_rows), n_c, t_c);
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
