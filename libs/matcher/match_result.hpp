#pragma once
// Outcome of matching one submap pair. Results are data: failures are statuses, not throws.

#include <Eigen/Core>
#include <string>

namespace maptune::matcher {

enum class MatchStatus {
    kOk,       // a transform was found and passed the checks: the pair counts as matched
    kNoMatch,  // the pipeline ran but found no consistent, plausible transform
    kFailed,   // input unusable (empty, too few points/keypoints, degenerate) - see reason
    kTimeout,  // the pair or evaluation time limit expired
};

const char* to_string(MatchStatus status);

struct PairResult {
    bool matched = false;  // status == kOk
    Eigen::Matrix4d T_a_b =
        Eigen::Matrix4d::Identity();  // pose of b in a's frame; valid iff matched
    // Pair stage [s] (descriptor matching, grouping, RANSAC, ICP), wall clock; the descriptor
    // matching's time counts even when its result came from the cache.
    double duration_s = 0.0;
    MatchStatus status = MatchStatus::kFailed;
    std::string reason;  // empty for kOk

    // Counters, for diagnosis and the sweeps.
    int keypoints_a = 0;
    int keypoints_b = 0;
    int correspondences = 0;   // after bidirectional union and dedup
    int groups = 0;            // Hough bins with >= n_TF votes
    int collinear_groups = 0;  // groups dropped by the line test
    int group_size = 0;        // correspondences in the chosen group
    int ransac_inliers = 0;
    double icp_fitness = -1.0;  // mean squared distance of ICP inliers [m^2]; -1 if not run
    double icp_inlier_fraction =
        -1.0;  // b's ICP points within the ICP distance of a; -1 if not run

    // Stage times [s] within duration_s.
    double descriptor_s = 0.0;  // correspondence search
    double grouping_s = 0.0;    // Hough, collinearity, RANSAC
    double icp_s = 0.0;
    // [s] computing both submaps' features (normals, keypoints, CSHOT, LRFs), as recorded when
    // they were computed: with duration_s, what the pair costs from the raw submaps.
    double features_s = 0.0;
};

}  // namespace maptune::matcher
