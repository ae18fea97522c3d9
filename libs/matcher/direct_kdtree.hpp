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
    using Ptr = std::shared_ptr<DirectKdTree<PointT>>;
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
        const std::size_t n = mapping_.size();
        const std::size_t want = k > 0 ? std::min(static_cast<std::size_t>(k), n) : 0;
        k_indices.resize(want);
        k_sqr_distances.resize(want);
        if (want == 0 || !index_) return 0;
        const float q[3] = {point.x, point.y, point.z};
        const flann::SearchParams params(-1, 0.0f);  // pcl::KdTreeFLANN's param_k_
        thread_local std::vector<std::size_t> found;
        found.resize(want);
        // FLANN's knnSearch: a simple result set up to 250 neighbours, a heap beyond.
        std::size_t got = 0;
        if (want > 250) {
            flann::KNNResultSet2<float> set(want);
            index_->findNeighbors(set, q, params);
            got = std::min(set.size(), want);
            set.copy(found.data(), k_sqr_distances.data(), got, params.sorted);
        } else {
            flann::KNNSimpleResultSet<float> set(want);
            index_->findNeighbors(set, q, params);
            got = std::min(set.size(), want);
            set.copy(found.data(), k_sqr_distances.data(), got, params.sorted);
        }
        for (std::size_t i = 0; i < got; ++i) k_indices[i] = mapping_[found[i]];
        return static_cast<int>(want);
    }

    int radiusSearch(const PointT& point, double radius, pcl::Indices& k_indices,
                     std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override {
        k_indices.clear();
        k_sqr_distances.clear();
        const std::size_t n = mapping_.size();
        if (!index_ || n == 0) return 0;
        const float q[3] = {point.x, point.y, point.z};
        const flann::SearchParams params(-1, 0.0f, this->sorted_results_);  // KdTreeFLANN's param_radius_
        const float r2 = static_cast<float>(radius * radius);
        thread_local std::vector<std::size_t> found;
        std::size_t got = 0;
        if (max_nn == 0 || max_nn >= n) {
            flann::RadiusResultSet<float> set(r2);
            index_->findNeighbors(set, q, params);
            got = set.size();
            found.resize(got);
            k_sqr_distances.resize(got);
            if (got > 0) set.copy(found.data(), k_sqr_distances.data(), got, params.sorted);
        } else {
            flann::KNNRadiusResultSet<float> set(r2, max_nn);
            index_->findNeighbors(set, q, params);
            got = std::min<std::size_t>(set.size(), max_nn);
            found.resize(got);
            k_sqr_distances.resize(got);
            if (got > 0) set.copy(found.data(), k_sqr_distances.data(), got, params.sorted);
        }
        k_indices.resize(got);
        for (std::size_t i = 0; i < got; ++i) k_indices[i] = mapping_[found[i]];
        return static_cast<int>(got);
    }

private:
    using Index = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;
    std::vector<float> xyz_;
    std::vector<pcl::index_t> mapping_;  // FLANN row -> index into the input cloud
    std::unique_ptr<Index> index_;
};

}  // namespace maptune::matcher
