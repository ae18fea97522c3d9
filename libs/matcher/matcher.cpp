#include "matcher/matcher.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include "matcher/descriptor_matching.hpp"
#include "matcher/grouping.hpp"
#include "matcher/icp.hpp"

namespace maptune::matcher {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::uint64_t fnv1a(const std::string& s, std::uint64_t h = 1469598103934665603ULL) {
    for (unsigned char c : s) {
        h ^= c;
        h *= 1099511628211ULL;
    }
    return h;
}

template <typename Fn>
void parallel_for(int n, int threads, Fn&& fn) {
    threads = std::max(1, std::min(threads, n));
    if (threads == 1) {
        for (int i = 0; i < n; ++i) fn(i);
        return;
    }
    std::atomic<int> next{0};
    std::vector<std::thread> pool;
    pool.reserve(static_cast<std::size_t>(threads));
    for (int t = 0; t < threads; ++t)
        pool.emplace_back([&] {
            for (int i = next++; i < n; i = next++) fn(i);
        });
    for (auto& th : pool) th.join();
}

PairResult finish(PairResult r, MatchStatus status, std::string reason,
                  std::chrono::steady_clock::time_point t0) {
    r.status = status;
    r.matched = status == MatchStatus::kOk;
    r.reason = std::move(reason);
    r.duration_s = seconds_since(t0);
    return r;
}

}  // namespace

const char* to_string(MatchStatus status) {
    switch (status) {
        case MatchStatus::kOk:
            return "OK";
        case MatchStatus::kNoMatch:
            return "NO_MATCH";
        case MatchStatus::kFailed:
            return "FAILED";
        case MatchStatus::kTimeout:
            return "TIMEOUT";
    }
    return "?";
}

std::uint64_t pair_seed(std::uint64_t seed, const std::string& id_a, const std::string& id_b) {
    std::uint64_t h = fnv1a(id_a, 1469598103934665603ULL ^ seed);
    h = fnv1a("|" + id_b, h);
    return h ^ (seed * 0x9E3779B97F4A7C15ULL);
}

PairResult match_features(const SubmapFeatures& a, const SubmapFeatures& b,
                          const MatcherParams& params, const MatcherSettings& settings,
                          const Deadline& deadline, std::uint64_t seed,
                          const NeighbourLists* neighbours) {
    const auto t0 = std::chrono::steady_clock::now();
    PairResult r;
    for (const auto* f : {&a, &b}) {
        if (f->status != FeatureStatus::kOk) {
            const char* which = f == &a ? "submap a: " : "submap b: ";
            return finish(
                r,
                f->status == FeatureStatus::kTimeout ? MatchStatus::kTimeout : MatchStatus::kFailed,
                which + f->reason, t0);
        }
    }
    r.keypoints_a = a.num_keypoints();
    r.keypoints_b = b.num_keypoints();
    const int min_kp = std::max(3, settings.min_keypoints);
    if (r.keypoints_a < min_kp || r.keypoints_b < min_kp)
        return finish(r, MatchStatus::kFailed, "too few keypoints", t0);

    // 7. Bidirectional correspondences.
    const auto corrs =
        neighbours && params.n_C <= neighbours->k
            ? select_correspondences(*neighbours, params.n_C, params.t_C)
            : match_descriptors(a.descriptors, b.descriptors, params.n_C, params.t_C);
    r.correspondences = static_cast<int>(corrs.size());
    r.descriptor_s = seconds_since(t0);
    const auto t_group = std::chrono::steady_clock::now();
    if (deadline.expired())
        return finish(r, MatchStatus::kTimeout, "pair time limit after correspondences", t0);
    if (r.correspondences < 3)
        return finish(r, MatchStatus::kNoMatch, "too few correspondences", t0);

    // 8. Hough grouping, collinearity check, largest remaining group.
    const auto hough = hough_groups(a, b, corrs, params.v_TF, params.n_TF);
    r.groups = static_cast<int>(hough.groups.size());
    if (hough.groups.empty())
        return finish(r, MatchStatus::kNoMatch,
                      "no Hough bin with n_TF votes (fullest " + std::to_string(hough.largest_bin) + " of " +
                          std::to_string(r.correspondences) + " correspondences; keypoints " +
                          std::to_string(r.keypoints_a) + "/" + std::to_string(r.keypoints_b) + ")",
                      t0);
    const double line_thr = settings.line_threshold_m > 0 ? settings.line_threshold_m : params.v_K;
    const std::vector<int>* chosen = nullptr;
    for (const auto& g : hough.groups) {
        if (deadline.expired())
            return finish(r, MatchStatus::kTimeout, "pair time limit during grouping", t0);
        std::vector<Eigen::Vector3f> pts;
        pts.reserve(g.size());
        for (int c : g) pts.push_back(a.keypoints.col(corrs[static_cast<std::size_t>(c)].a));
        if (is_collinear(pts, line_thr, settings.collinear_inlier_fraction,
                         settings.line_ransac_iterations, seed ^ 0x5bd1e995ULL)) {
            ++r.collinear_groups;
            continue;
        }
        chosen = &g;
        break;
    }
    if (!chosen) return finish(r, MatchStatus::kNoMatch, "all groups collinear", t0);
    r.group_size = static_cast<int>(chosen->size());

    // 9. RANSAC rigid transform on the group, then ICP on the full clouds.
    Eigen::Matrix3Xf pa(3, r.group_size), pb(3, r.group_size);
    for (int k = 0; k < r.group_size; ++k) {
        const auto& c = corrs[static_cast<std::size_t>((*chosen)[static_cast<std::size_t>(k)])];
        pa.col(k) = a.keypoints.col(c.a);
        pb.col(k) = b.keypoints.col(c.b);
    }
    const double ransac_thr =
        settings.ransac_inlier_threshold_m > 0 ? settings.ransac_inlier_threshold_m
        : settings.ransac_threshold_from == MatcherSettings::ThresholdFrom::kVTF ? params.v_TF
                                                                                : params.v_K;
    const auto ransac =
        ransac_rigid(pa, pb, ransac_thr, settings.ransac_iterations, seed, deadline);
    if (ransac.timed_out) return finish(r, MatchStatus::kTimeout, "pair time limit in RANSAC", t0);
    r.ransac_inliers = static_cast<int>(ransac.inliers.size());
    if (!ransac.ok) return finish(r, MatchStatus::kNoMatch, "RANSAC found no rigid transform", t0);
    const int min_inliers = settings.consensus_from_n_TF ? std::max(settings.min_ransac_inliers, params.n_TF)
                                                         : settings.min_ransac_inliers;
    if (r.ransac_inliers < min_inliers)
        return finish(r, MatchStatus::kNoMatch, "too few RANSAC inliers", t0);
    Eigen::Matrix4f T = ransac.T_a_b;
    r.grouping_s = seconds_since(t_group);
    const auto t_icp = std::chrono::steady_clock::now();
    if (settings.icp_enabled) {
        const double max_corr = settings.icp_max_correspondence_m > 0
                                    ? settings.icp_max_correspondence_m
                                    : 2.0 * params.v_K;
        const auto icp = refine_icp(a, b, T, max_corr, settings.icp_max_iterations,
                                    settings.icp_point_to_plane);
        if (icp.ok) {
            T = icp.T_a_b;
            r.icp_fitness = icp.fitness;
            r.icp_inlier_fraction = icp.inlier_fraction;
        }
    }
    r.icp_s = seconds_since(t_icp);
    if (deadline.expired()) return finish(r, MatchStatus::kTimeout, "pair time limit in ICP", t0);
    r.T_a_b = T.cast<double>();

    // 10. Decision: a transform was found (consensus checked above, before the costly ICP);
    // optional overlap and roll/pitch plausibility.
    if (settings.min_icp_inlier_fraction > 0 && settings.icp_enabled &&
        r.icp_inlier_fraction < settings.min_icp_inlier_fraction)
        return finish(r, MatchStatus::kNoMatch, "too little overlap after ICP", t0);
    if (settings.max_free_space_fraction > 0) {
        // 400 points a direction decide a fraction to a few hundredths; 20 known ones at least,
        // or the submaps saw too little of each other's space to argue either way.
        const auto fs = free_space_counts(a, b, T, settings.free_space_margin_m, 400);
        const double worst = fs.worst_fraction(20);
        if (worst > settings.max_free_space_fraction) {
            char text[160];
            std::snprintf(text, sizeof text,
                          "free space contradicts the match (%.2f of the points in known space; b in a %d/%d, a in b %d/%d)",
                          worst, fs.free, fs.known, fs.reverse_free, fs.reverse_known);
            return finish(r, MatchStatus::kNoMatch, text, t0);
        }
    }
    if (settings.max_roll_pitch_rad > 0) {
        const Eigen::Matrix3d R = r.T_a_b.topLeftCorner<3, 3>();
        const double roll = std::atan2(R(2, 1), R(2, 2));
        const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
        if (std::abs(roll) > settings.max_roll_pitch_rad ||
            std::abs(pitch) > settings.max_roll_pitch_rad)
            return finish(r, MatchStatus::kNoMatch, "implausible roll/pitch", t0);
    }
    return finish(r, MatchStatus::kOk, "", t0);
}

Matcher::Matcher(MatcherSettings settings, FeatureCacheOptions cache_options)
    : settings_(settings),
      cache_(cache_options),
      neighbour_cache_(cache_options.max_neighbour_bytes, cache_options.max_entries) {
    silence_pcl_console();
}

std::shared_ptr<const NeighbourLists> Matcher::neighbours(const SubmapFeatures& a,
                                                          const SubmapFeatures& b,
                                                          const std::string& key_a,
                                                          const std::string& key_b) {
    if (cache_.options().max_neighbour_bytes == 0) return nullptr;
    return neighbour_cache_.get_or_compute(key_a + "||" + key_b, [&] {
        const auto t0 = std::chrono::steady_clock::now();
        auto lists = std::make_shared<NeighbourLists>(
            nearest_descriptors(a.descriptors, b.descriptors, kNeighbourListLength));
        lists->compute_s = seconds_since(t0);
        return std::shared_ptr<const NeighbourLists>(std::move(lists));
    });
}

int Matcher::thread_count() const {
    if (settings_.threads > 0) return settings_.threads;
    return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

std::shared_ptr<const SubmapFeatures> Matcher::features(const dataset::Submap& submap,
                                                        const MatcherParams& params,
                                                        const Deadline& deadline) {
    const double quantum = cache_.options().key_quantum;
    const MatcherParams q = quantize_feature_params(params, quantum);
    return features(submap, q, feature_key(submap, q, settings_, quantum), deadline);
}

std::shared_ptr<const SubmapFeatures> Matcher::features(const dataset::Submap& submap,
                                                        const MatcherParams& q,
                                                        const std::string& key,
                                                        const Deadline& deadline) {
    return cache_.get_or_compute(key, [&] {
        const Deadline d =
            Deadline::earliest(deadline, Deadline::in(settings_.submap_time_limit_s));
        return compute_features(submap, q, settings_, d);
    });
}

PairResult Matcher::match(const dataset::Submap& a, const dataset::Submap& b,
                          const MatcherParams& params) {
    std::vector<const dataset::Submap*> s{&a, &b};
    return match_pairs(s, {{0, 1}}, params).front();
}

std::vector<PairResult> Matcher::match_pairs(const std::vector<dataset::Submap>& submaps,
                                             const std::vector<std::pair<int, int>>& pairs,
                                             const MatcherParams& params, EvaluationStats* stats) {
    std::vector<const dataset::Submap*> ptrs;
    ptrs.reserve(submaps.size());
    for (const auto& s : submaps) ptrs.push_back(&s);
    return match_pairs(ptrs, pairs, params, stats);
}

std::vector<PairResult> Matcher::match_pairs(const std::vector<const dataset::Submap*>& submaps,
                                             const std::vector<std::pair<int, int>>& pairs,
                                             const MatcherParams& params, EvaluationStats* stats) {
    const auto t_start = std::chrono::steady_clock::now();
    const Deadline total = Deadline::in(settings_.total_time_limit_s);
    const auto cache_before = cache_.stats();
    const auto neighbours_before = neighbour_cache_.stats();
    std::vector<PairResult> results(pairs.size());

    // Submaps involved in valid pairs.
    const int n = static_cast<int>(submaps.size());
    std::vector<char> used(submaps.size(), 0);
    for (const auto& [i, j] : pairs)
        if (i >= 0 && j >= 0 && i < n && j < n && submaps[static_cast<std::size_t>(i)] &&
            submaps[static_cast<std::size_t>(j)])
            used[static_cast<std::size_t>(i)] = used[static_cast<std::size_t>(j)] = 1;
    std::vector<int> todo;
    for (int i = 0; i < n; ++i)
        if (used[static_cast<std::size_t>(i)]) todo.push_back(i);

    std::vector<std::shared_ptr<const SubmapFeatures>> feats(submaps.size());
    std::vector<std::string> keys(submaps.size());
    const double quantum = cache_.options().key_quantum;
    const MatcherParams quantized = quantize_feature_params(params, quantum);
    for (int i : todo)
        keys[static_cast<std::size_t>(i)] =
            feature_key(*submaps[static_cast<std::size_t>(i)], quantized, settings_, quantum);
    parallel_for(static_cast<int>(todo.size()), thread_count(), [&](int k) {
        const int i = todo[static_cast<std::size_t>(k)];
        if (total.expired()) {
            auto f = std::make_shared<SubmapFeatures>();
            f->submap_id = submaps[static_cast<std::size_t>(i)]->id;
            f->status = FeatureStatus::kTimeout;
            f->reason = "evaluation time limit before features";
            feats[static_cast<std::size_t>(i)] = f;
            return;
        }
        feats[static_cast<std::size_t>(i)] = features(*submaps[static_cast<std::size_t>(i)],
                                                      quantized, keys[static_cast<std::size_t>(i)],
                                                      total);
    });
    const auto t_features = std::chrono::steady_clock::now();

    parallel_for(static_cast<int>(pairs.size()), thread_count(), [&](int k) {
        const auto [i, j] = pairs[static_cast<std::size_t>(k)];
        PairResult& r = results[static_cast<std::size_t>(k)];
        if (i < 0 || j < 0 || i >= n || j >= n || !feats[static_cast<std::size_t>(i)] ||
            !feats[static_cast<std::size_t>(j)]) {
            r.status = MatchStatus::kFailed;
            r.reason = "invalid pair index";
            return;
        }
        if (total.expired()) {
            r.status = MatchStatus::kTimeout;
            r.reason = "evaluation time limit";
            return;
        }
        const Deadline d = Deadline::earliest(total, Deadline::in(settings_.pair_time_limit_s));
        const auto& fa = *feats[static_cast<std::size_t>(i)];
        const auto& fb = *feats[static_cast<std::size_t>(j)];
        // Step 7's GEMM depends only on the two submaps' features: cached per pair, so a new
        // set of pair-stage parameters (n_C, t_C, v_TF, n_TF) does not repeat it.
        std::shared_ptr<const NeighbourLists> lists;
        if (fa.status == FeatureStatus::kOk && fb.status == FeatureStatus::kOk &&
            params.n_C <= kNeighbourListLength)
            lists = neighbours(fa, fb, keys[static_cast<std::size_t>(i)],
                               keys[static_cast<std::size_t>(j)]);
        // What computing them took, cached or not: a pair's time does not depend on the cache.
        const double lists_s = lists ? lists->compute_s : 0.0;
        r = match_features(fa, fb, params, settings_, d,
                           pair_seed(settings_.seed, submaps[static_cast<std::size_t>(i)]->id,
                                     submaps[static_cast<std::size_t>(j)]->id),
                           lists.get());
        r.descriptor_s += lists_s;
        r.duration_s += lists_s;
        r.features_s = fa.duration_s + fb.duration_s;
    });

    if (stats) {
        const auto cache_after = cache_.stats();
        stats->submaps = static_cast<int>(todo.size());
        stats->pairs = static_cast<int>(pairs.size());
        stats->feature_wall_s = std::chrono::duration<double>(t_features - t_start).count();
        stats->pair_wall_s = seconds_since(t_features);
        stats->cache_hits = cache_after.hits - cache_before.hits;
        stats->cache_misses = cache_after.misses - cache_before.misses;
        stats->neighbour_hits = neighbour_cache_.stats().hits - neighbours_before.hits;
        stats->failed = stats->timeouts = stats->matched = 0;
        for (const auto& r : results) {
            stats->failed += r.status == MatchStatus::kFailed;
            stats->timeouts += r.status == MatchStatus::kTimeout;
            stats->matched += r.matched;
        }
    }
    return results;
}

}  // namespace maptune::matcher
