#pragma once
// Per-submap features (SPEC §3 steps 1-6). They depend only on the submap, the per-submap
// parameters (r_N, v_K, t_K, r_D, r_LRF) and the feature settings, so they are computed once
// and cached (feature_cache.hpp). PCL types stay behind an opaque pointer.

#include <Eigen/Core>
#include <chrono>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "dataset/submap.hpp"
#include "matcher/matcher_params.hpp"

namespace maptune::matcher {

inline constexpr int kDescriptorSize = 1344;  // CSHOT: 352 shape + 992 colour bins

// One row per keypoint, unit L2 norm (all entries are >= 0).
using DescriptorMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct Deadline {
    std::chrono::steady_clock::time_point at = std::chrono::steady_clock::time_point::max();
    static Deadline in(double seconds);
    bool expired() const { return std::chrono::steady_clock::now() >= at; }
    static Deadline earliest(const Deadline& a, const Deadline& b) { return a.at < b.at ? a : b; }
};

struct IcpCloud;  // PCL cloud + k-d tree for ICP, defined in features.cpp

enum class FeatureStatus { kOk, kFailed, kTimeout };

struct SubmapFeatures {
    std::string submap_id;
    FeatureStatus status = FeatureStatus::kFailed;
    std::string reason;  // why not kOk

    Eigen::Matrix3Xf keypoints;         // submap frame [m], one column per keypoint
    DescriptorMatrix descriptors;       // rows match keypoint columns
    std::vector<Eigen::Matrix3f> lrfs;  // rows: x, y, z axes in the submap frame
    Eigen::Vector3f keypoint_centroid = Eigen::Vector3f::Zero();
    std::shared_ptr<const IcpCloud> icp_cloud;
    // The submap's OctoMap, kept only for the free-space check (max_free_space_fraction > 0).
    std::shared_ptr<const octomap::OcTree> octree;

    // Counters.
    int points_in = 0;
    int points_filtered = 0;           // after outlier removal
    int keypoint_candidates = 0;       // obstacle points, or cloud points as fallback
    bool used_cloud_fallback = false;  // submap had no obstacle points
    int keypoints_voxel = 0;           // after v_K thinning and snapping
    int keypoints_unknown = 0;         // after the unknown-space filter
    int invalid_descriptors = 0;       // CSHOT aborted (PCL would have printed a warning)
    int invalid_lrfs = 0;              // LRF invalid (PCL would have printed a warning)
    int invalid_normals = 0;
    double duration_s = 0.0;

    int num_keypoints() const { return static_cast<int>(keypoints.cols()); }
    std::size_t bytes() const;  // approximate memory footprint, for the cache bound
};

// Computes features with the per-submap parameters of `params` exactly as given (the cache
// quantizes them first). Never throws for bad input: status and reason say what happened.
std::shared_ptr<const SubmapFeatures> compute_features(const dataset::Submap& submap,
                                                       const MatcherParams& params,
                                                       const MatcherSettings& settings,
                                                       const Deadline& deadline = {});

// The free-space check of a match (MatcherSettings::max_free_space_fraction): of b's ICP source
// points placed in a by T_a_b, how many fall in a's known space and how many of those in free
// space with no occupied cell within margin_m; `reverse` the same for a's points in b. At most
// max_points points per direction (evenly strided). Zero counts where a feature set has no
// octree or ICP cloud.
struct FreeSpaceCounts {
    int known = 0, free = 0;                  // b in a
    int reverse_known = 0, reverse_free = 0;  // a in b
    // The larger of the two directions' free / known among those with at least min_known points.
    double worst_fraction(int min_known) const;
};
FreeSpaceCounts free_space_counts(const SubmapFeatures& a, const SubmapFeatures& b,
                                  const Eigen::Matrix4f& T_a_b, double margin_m, int max_points);

// Points of the ICP cloud (for tests and diagnostics).
std::size_t icp_cloud_size(const SubmapFeatures& features);

// Silences PCL's console output process-wide (idempotent); the matcher counts the events
// instead (invalid_descriptors, invalid_lrfs).
void silence_pcl_console();

}  // namespace maptune::matcher
