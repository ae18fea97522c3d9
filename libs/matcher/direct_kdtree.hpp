#pragma once
// Internal to libs/matcher (PCL translation units only): a k-d tree with PCL's search interface
// that answers single-point queries without an OpenMP region per query.
//
// pcl::KdTreeFLANN wraps every single-point query in FLANN's batch search, which opens an
// OpenMP parallel region (a team allocated and freed by libgomp) for one point. ICP asks one
// query per source point per iteration, the features one per surface point: in the service
// (several threads, bounded malloc arenas) that overhead was ~45 % of a pair-stage-only
// evaluation's CPU (BENCHMARKS.md, "Full moon scale"). This tree builds the same FLANN index
// (KDTreeSingleIndex, 15 points per leaf, xyz of the finite points) and runs the same result
// sets as FLANN's searches do, directly: same neighbours, same order, same distances.

#include <flann/algorithms/dist.h>
#include <flann/algorithms/kdtree_single_index.h>
#include <flann/util/result_set.h>
#include <pcl/search/kdtree.h>

#include <cmath>
#include <memory>
#include <vector>

namespace maptune::matcher {

template <typename PointT>
class DirectKdTree : public pcl::search::KdTree<PointT> {
public:
    using typename pcl::search::KdTree<PointT>::PointCloudConstPtr;
    using IndicesConstPtr = pcl::IndicesConstPtr;
    using pcl::search::KdTree<PointT>::nearestKSearch;
    using pcl::search::KdTree<PointT>::radiusSearch;

    // sorted: radius results by distance (as pcl::search::KdTree; PCL's estimators default
    // to unsorted, and the order changes their floating-point sums). k-NN is always sorted.
    explicit DirectKdTree(bool sorted = true) : pcl::search::KdTree<PointT>(sorted) {}

    // The base class's own FLANN tree is never built: every query is answered here.
    void setInputCloud(const PointCloudConstPtr& cloud,
                       const IndicesConstPtr& indices = IndicesConstPtr()) override {
        this->input_ = cloud;
        this->indices_ = indices;
        xyz_.clear();
        mapping_.clear();
        index_.reset();
        if (!cloud) return;
        auto add = [&](pcl::index_t i) {
            const PointT& p = (*cloud)[static_cast<std::size_t>(i)];
            // As pcl::KdTreeFLANN: points with a non-finite coordinate are left out.
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return;
            xyz_.insert(xyz_.end(), {p.x, p.y, p.z});
            mapping_.push_back(i);
        };
        if (indices) {
            for (const auto i : *indices) add(i);
        } else {
            for (std::size_t i = 0; i < cloud->size(); ++i) add(static_cast<pcl::index_t>(i));
        }
        if (mapping_.empty()) return;
        index_ = std::make_unique<Index>(flann::Matrix<float>(xyz_.data(), mapping_.size(), 3),
                                         flann::KDTreeSingleIndexParams(15));
        index_->buildIndex();
    }

    int nearestKSearch(const PointT& point, int k, pcl::Indices& k_indices,
                       std::vector<float>& k_sqr_distances) const override {
        const std::size_t want = k > 0 ? std::min(static_cast<std::size_t>(k), mapping_.size()) : 0;
        k_indices.clear();
        k_sqr_distances.clear();
        if (want == 0) return 0;
        const flann::SearchParams params(-1, 0.0f);  // pcl::KdTreeFLANN's param_k_
        // FLANN's knnSearch: a simple result set up to 250 neighbours, a heap beyond.
        if (want > 250) {
            flann::KNNResultSet2<float> set(want);
            return collect(set, point, params, want, k_indices, k_sqr_distances);
        }
        flann::KNNSimpleResultSet<float> set(want);
        return collect(set, point, params, want, k_indices, k_sqr_distances);
    }

    int radiusSearch(const PointT& point, double radius, pcl::Indices& k_indices,
                     std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override {
        const std::size_t n = mapping_.size();
        k_indices.clear();
        k_sqr_distances.clear();
        if (n == 0) return 0;
        const flann::SearchParams params(-1, 0.0f, this->sorted_results_);  // KdTreeFLANN's param_radius_
        const float r2 = static_cast<float>(radius * radius);
        if (max_nn == 0 || max_nn >= n) {
            flann::RadiusResultSet<float> set(r2);
            return collect(set, point, params, n, k_indices, k_sqr_distances);
        }
        flann::KNNRadiusResultSet<float> set(r2, max_nn);
        return collect(set, point, params, max_nn, k_indices, k_sqr_distances);
    }

private:
    using Index = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;

    // One FLANN search with `set`, as FLANN's batch searches run it for each query: at most
    // `limit` results, copied (sorted or not, per `params`) and mapped to cloud indices.
    template <class ResultSet>
    int collect(ResultSet& set, const PointT& point, const flann::SearchParams& params, std::size_t limit,
                pcl::Indices& indices, std::vector<float>& sqr_distances) const {
        const float q[3] = {point.x, point.y, point.z};
        index_->findNeighbors(set, q, params);
        const std::size_t got = std::min(set.size(), limit);
        thread_local std::vector<std::size_t> found;
        found.resize(got);
        indices.resize(got);
        sqr_distances.resize(got);
        if (got > 0) set.copy(found.data(), sqr_distances.data(), got, params.sorted);
        for (std::size_t i = 0; i < got; ++i) indices[i] = mapping_[found[i]];
        return static_cast<int>(got);
    }

    std::vector<float> xyz_;
    std::vector<pcl::index_t> mapping_;  // FLANN row -> index into the input cloud
    std::unique_ptr<Index> index_;
};

}  // namespace maptune::matcher
