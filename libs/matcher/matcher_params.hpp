#pragma once
// Typed parameters of the reference matcher (SPEC §3). The nine optimized parameters keep the
// thesis's symbols; everything else is a non-optimized setting with a fixed default.

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace maptune::matcher {

// The nine parameters of SPEC §3, Table 5.1. Defaults are x_baseline.
struct MatcherParams {
    double r_N = 0.2;    // normal estimation radius [m], bounds [0.1, 2]
    double v_K = 0.1;    // keypoint voxel grid leaf size [m], bounds [0.05, 0.5]
    double t_K = 1.0;    // keep a keypoint iff its unknown-space fraction u <= t_K, [0, 1]
    double r_D = 0.2;    // CSHOT descriptor radius [m], also the unknown-space radius, [0.1, 2]
    int n_C = 3;         // max correspondences per keypoint and direction, [1, 10]
    double t_C = 0.5;    // max normalized descriptor distance (see docs/matcher.md), [0, 1]
    double r_LRF = 0.2;  // local reference frame radius for Hough voting [m], [0.1, 1]
    double v_TF = 0.5;   // Hough voting bin size [m], [0.1, 1]
    int n_TF = 8;        // min votes of a Hough bin to form a group, [3, 300]
};

// Names in the generic name -> value map, in table order.
inline const std::vector<std::string>& parameter_names() {
    static const std::vector<std::string> names{"r_N", "v_K",   "t_K",  "r_D", "n_C",
                                                "t_C", "r_LRF", "v_TF", "n_TF"};
    return names;
}

// The one place where the generic named-value form is converted to and from MatcherParams.
// Missing keys keep the baseline; unknown keys are ignored (the caller validates the space);
// integers are rounded to the nearest integer.
MatcherParams from_named_values(const std::map<std::string, double>& values);
std::map<std::string, double> to_named_values(const MatcherParams& params);

// Clamps every parameter into its SPEC bounds; returns the number of clamped values.
int clamp_to_bounds(MatcherParams& params);

enum class LrfMethod { kShot, kBoard };

// Non-optimized settings: fixed per experiment, part of the feature cache key where they
// influence per-submap results (see feature_settings_fingerprint).
struct MatcherSettings {
    // Step 1: statistical outlier removal.
    bool outlier_removal = true;
    int outlier_mean_k = 20;          // neighbours for the mean distance
    double outlier_stddev_mul = 2.0;  // keep points within mean + mul * stddev

    // Neighbourhood bounding: radius searches (normals, CSHOT, LRF) run on a copy of the
    // filtered cloud voxelized at radius / surface_points_per_radius (only when that is
    // coarser than the cloud), so a ball holds at most ~pi * k^2 surface points whatever the
    // radius. This is what keeps r_N = r_D = 2 m on a dense cloud bounded.
    double surface_points_per_radius = 10.0;

    // Step 6: LRF algorithm for Hough voting.
    LrfMethod lrf_method = LrfMethod::kShot;

    // Step 4: unknown-space sampling. The ball of radius r_D is sampled on a grid of step
    // max(octree resolution, 2 r_D / unknown_samples_per_diameter).
    double unknown_samples_per_diameter = 16.0;

    // Normals are flipped towards this point of the submap frame (the sensor side).
    double viewpoint_x = 0.0, viewpoint_y = 0.0, viewpoint_z = 0.0;

    // Step 8: collinearity check of a Hough group by a RANSAC line fit on its keypoints:
    // the group is dropped if at least this fraction lies within line_threshold of one line.
    double collinear_inlier_fraction = 0.9;
    double line_threshold_m = 0.0;  // <= 0: use v_K
    int line_ransac_iterations = 100;

    // Step 9: RANSAC rigid transform on the largest group, then ICP on the filtered clouds.
    int ransac_iterations = 10000;  // cap; stops earlier at 99.9 % confidence
    // Corresponding keypoints sit up to ~v_K/2 apart (voxel thinning), hence v_K-based defaults.
    double ransac_inlier_threshold_m = 0.0;  // > 0: fixed; <= 0: from ransac_threshold_from
    // Which parameter sets the RANSAC inlier threshold when it is not fixed: v_K (keypoint
    // spacing, maptune's default) or v_TF (the Hough bin size, as PCL's Hough3DGrouping —
    // the thesis's grouping — sets it: setInlierThreshold(hough_bin_size)).
    enum class ThresholdFrom { kVK, kVTF };
    ThresholdFrom ransac_threshold_from = ThresholdFrom::kVK;
    int icp_max_iterations = 15;  // point-to-plane converges in fewer on lab pairs (measured)
    double icp_max_correspondence_m = 0.0;  // <= 0: use 2 v_K
    // ICP clouds are voxelized at this leaf (<= 0: the filtered cloud as is). ICP dominates the
    // pair stage on dense clouds; 0.1 m keeps lab-scale errors well below e* = 0.4 m.
    double icp_voxel_m = 0.1;
    bool icp_enabled = true;
    // Point-to-plane ICP (normals of the ICP cloud within 3 icp_voxel_m, or r_N without a
    // voxel): converges in a few iterations where point-to-point slides along the floor for
    // all 30 (measured: ICP was 60 % of the lab pair stage). false: point-to-point.
    bool icp_point_to_plane = true;
    // The ICP source (b) is thinned to one point per voxel of this many icp_voxel_m (<= 1: the
    // whole ICP cloud); the target keeps full resolution. 2 = a quarter of the searches.
    double icp_source_voxel_factor = 2.0;

    // Step 10: optional plausibility check for ground robots (submap frames gravity
    // aligned): relative roll and pitch must stay below this bound. <= 0 disables it.
    double max_roll_pitch_rad = 0.0;
    // Optional overlap check: after ICP, at least this fraction of b's ICP points must lie
    // within the ICP correspondence distance of a. <= 0 disables it (SPEC default).
    double min_icp_inlier_fraction = 0.0;
    // Optional free-space check (a loop-closure verification the thesis's pipeline lacks): b's
    // ICP points placed in a by the match, and a's in b, must not lie where the other submap's
    // OctoMap saw free space with no occupied cell within free_space_margin_m. The match is
    // rejected when more than this fraction of the points that fall in known space do so (in
    // either direction). A wrong match lays one submap's rocks into the other's observed air;
    // consensus and ICP overlap cannot see that ("ground fits ground"). <= 0 disables it.
    double max_free_space_fraction = 0.0;
    double free_space_margin_m = 0.1;  // covers a correct match's residual error and the cell size
    // Consensus check (the thesis, §3.2: matchers decide "by thresholding the number of inlier
    // correspondences"): the RANSAC transform must explain at least this many correspondences.
    // On the simulated lab, wrong matches end with 7-38 inliers (median 18) and correct ones
    // with 10-245 (median 65), see BENCHMARKS.md; without it every pair "matches". 0 disables.
    int min_ransac_inliers = 12;
    // The thesis names n_TF "TF estimation min correspondences": when true, the RANSAC
    // transform must also explain at least n_TF correspondences (required inliers =
    // max(min_ransac_inliers, n_TF)), so n_TF decides the match as its name says.
    bool consensus_from_n_TF = false;

    // Robustness.
    int min_points = 10;                 // fewer points after filtering -> FAILED
    int min_keypoints = 3;               // fewer keypoints -> FAILED
    double pair_time_limit_s = 60.0;     // per pair (pair stage) -> TIMEOUT
    double submap_time_limit_s = 120.0;  // per submap feature computation -> FAILED/TIMEOUT
    double total_time_limit_s = 3600.0;  // whole evaluation; pairs not done by then -> TIMEOUT

    std::uint64_t seed = 42;  // all randomness (RANSAC) is derived from it per pair
    int threads = 0;          // 0: hardware concurrency
};

// The one list of non-optimized settings (every field but `threads`, which does not change
// results): its name, whether it changes per-submap features, and how to write and read it
// as text. `--matcher`, experiments' matcher.settings, the settings a task carries, the
// matcher version and the feature fingerprint all come from it, so none can miss a field.
struct SettingField {
    std::string name;
    bool per_submap = false;
    std::function<std::string(MatcherSettings&, const std::string&)> set;  // "" or the error
    std::function<std::string(const MatcherSettings&)> get;                // text `set` takes back exactly
    // Settings added after matcher code revision 4 are left out of the matcher version and the
    // feature fingerprint while at their default, so the observations stored before stay valid.
    bool versioned_at_default = true;
};
const std::vector<SettingField>& setting_fields();
// Whether `f` at its value in `s` is part of the matcher version and feature fingerprint.
bool in_version(const SettingField& f, const MatcherSettings& s);

// Settings that change per-submap features, as a string for the cache key.
std::string feature_settings_fingerprint(const MatcherSettings& settings);
// "KEY=VALUE" for every setting in table order: applied to defaults by set_matcher_settings,
// it gives back these settings (what an evaluation task carries to any worker).
std::vector<std::string> setting_texts(const MatcherSettings& settings);

// Sets one non-optimized setting by its field name ("min_ransac_inliers", "icp_enabled", ...)
// from text, for `--matcher KEY=VALUE` (evaluate, sweep, compare). Returns an error naming the key
// and the value ("" when set); unknown keys list the known ones.
std::string set_matcher_setting(MatcherSettings& settings, const std::string& key,
                                const std::string& value);
// Applies "KEY=VALUE" texts in order (`--matcher` of the CLI and the worker). Returns an
// error naming the text ("--matcher KEY=VALUE: ..."), "" when all were set.
std::string set_matcher_settings(MatcherSettings& settings, const std::vector<std::string>& key_values);
// Every key set_matcher_setting accepts (its one table), sorted.
std::vector<std::string> matcher_setting_names();

}  // namespace maptune::matcher
