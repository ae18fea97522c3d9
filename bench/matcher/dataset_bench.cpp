// Evaluates the matcher on a dataset view (the core of `maptune evaluate`, without the
// measure library): m, error statistics and p against the view's reference, stage
// throughput, and the re-evaluation with only pair-stage parameters changed.
//
//   matcher_dataset_bench --dataset DIR [--view complete|subsequent] [--reference gt|odometry]
//       [--params k=v,...] [--pair-params k=v,...] [--runs N] [--threads T]
//       [--e-star 0.4] [--m-star N] [--total-limit S]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "dataset/dataset.hpp"
#include "matcher/descriptor_matching.hpp"
#include "matcher/grouping.hpp"
#include "matcher/matcher.hpp"

using namespace maptune;
using namespace maptune::matcher;

namespace {
std::map<std::string, double> parse_kv(const std::string& s) {
    std::map<std::string, double> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        if (auto eq = item.find('='); eq != std::string::npos)
            out[item.substr(0, eq)] = std::atof(item.c_str() + eq + 1);
    return out;
}
double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
double percentile(std::vector<double> v, double q) {
    if (v.empty()) return std::nan("");
    std::sort(v.begin(), v.end());
    return v[static_cast<std::size_t>(q * (v.size() - 1))];
}
}  // namespace

int main(int argc, char** argv) {
    std::string dir, view_s = "complete", ref_s = "gt", params_s, pair_params_s = "t_C=0.6,n_TF=10";
    std::setvbuf(stdout, nullptr, _IOLBF, 0);
    int max_runs = 1000, threads = 0, max_pairs = 1 << 30, verbose = 0;
    double e_star = 0.4, m_star = -1, total_limit = 3600, icp_voxel = 0.1;
    int board = 0;
    double min_overlap = 0, max_rp = 0;
    int min_inliers = MatcherSettings{}.min_ransac_inliers;
    int icp_iter = MatcherSettings{}.icp_max_iterations;
    FeatureCacheOptions cache;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string k = argv[i], v = argv[i + 1];
        if (k == "--dataset")
            dir = v;
        else if (k == "--view")
            view_s = v;
        else if (k == "--reference")
            ref_s = v;
        else if (k == "--params")
            params_s = v;
        else if (k == "--pair-params")
            pair_params_s = v;
        else if (k == "--runs")
            max_runs = std::atoi(v.c_str());
        else if (k == "--threads")
            threads = std::atoi(v.c_str());
        else if (k == "--max-pairs")
            max_pairs = std::atoi(v.c_str());
        else if (k == "--verbose")
            verbose = std::atoi(v.c_str());
        else if (k == "--e-star")
            e_star = std::atof(v.c_str());
        else if (k == "--m-star")
            m_star = std::atof(v.c_str());
        else if (k == "--total-limit")
            total_limit = std::atof(v.c_str());
        else if (k == "--board")
            board = std::atoi(v.c_str());
        else if (k == "--min-overlap")
            min_overlap = std::atof(v.c_str());
        else if (k == "--min-inliers")
            min_inliers = std::atoi(v.c_str());
        else if (k == "--max-roll-pitch-deg")
            max_rp = std::atof(v.c_str());
        else if (k == "--icp-iter")
            icp_iter = std::atoi(v.c_str());
        else if (k == "--icp-voxel")
            icp_voxel = std::atof(v.c_str());
        else if (k == "--feature-cache-mb")
            cache.max_bytes = static_cast<std::size_t>(std::atof(v.c_str()) * (1 << 20));
        else if (k == "--neighbour-cache-mb")
            cache.max_neighbour_bytes = static_cast<std::size_t>(std::atof(v.c_str()) * (1 << 20));
    }
    if (dir.empty()) {
        std::cerr << "usage: matcher_dataset_bench --dataset DIR [--view ..] [--reference ..] "
                     "[--params k=v,...] [--feature-cache-mb N] [--neighbour-cache-mb N]\n";
        return 2;
    }
    const auto ds = dataset::Dataset::open(dir);
    auto view_pairs = ds.pairs(dataset::parse_view(view_s), dataset::parse_reference(ref_s));
    view_pairs.erase(std::remove_if(view_pairs.begin(), view_pairs.end(),
                                    [&](const auto& p) { return p.run >= max_runs; }),
                     view_pairs.end());
    if (static_cast<int>(view_pairs.size()) > max_pairs)
        view_pairs.resize(static_cast<std::size_t>(max_pairs));

    const auto t_load = std::chrono::steady_clock::now();
    std::vector<dataset::Submap> submaps;
    std::map<std::pair<int, int>, int> index;
    std::vector<std::pair<int, int>> pairs;
    std::vector<double> sizes;
    for (const auto& p : view_pairs) {
        for (int s : {p.a, p.b}) {
            if (index.count({p.run, s})) continue;
            index[{p.run, s}] = static_cast<int>(submaps.size());
            submaps.push_back(ds.load_submap(p.run, s));
            sizes.push_back(ds.manifest()
                                .runs[static_cast<std::size_t>(p.run)]
                                .submaps[static_cast<std::size_t>(s)]
                                .size);
        }
        pairs.emplace_back(index[{p.run, p.a}], index[{p.run, p.b}]);
    }
    int overlapping = 0;
    for (const auto& p : view_pairs) overlapping += p.overlap > 0.1;
    if (m_star <= 0) m_star = std::max(1, overlapping);
    std::printf(
        "dataset %s, view %s/%s: %zu submaps, %zu pairs (%d with overlap > 0.1), load %.2f s\n",
        dir.c_str(), view_s.c_str(), ref_s.c_str(), submaps.size(), pairs.size(), overlapping,
        seconds_since(t_load));

    MatcherSettings settings;
    settings.threads = threads;
    settings.total_time_limit_s = total_limit;
    settings.icp_voxel_m = icp_voxel;
    if (board) settings.lrf_method = LrfMethod::kBoard;
    settings.min_icp_inlier_fraction = min_overlap;
    settings.min_ransac_inliers = min_inliers;
    settings.icp_max_iterations = icp_iter;
    settings.max_roll_pitch_rad = max_rp * M_PI / 180.0;
    Matcher matcher(settings, cache);

    auto evaluate = [&](const char* label, const MatcherParams& params) {
        EvaluationStats st;
        const auto t0 = std::chrono::steady_clock::now();
        const auto res = matcher.match_pairs(submaps, pairs, params, &st);
        const double wall = seconds_since(t0);
        // SPEC §2.
        const double k = std::log(39.0) / (e_star - 0.05);
        auto eps_t = [&](double x) { return 1.0 - 2.0 / (1.0 + std::exp(-k * (x - e_star))); };
        std::vector<double> et, er;
        double sum_r = 0;
        int m = 0, m_overlap = 0, no_match = 0;
        std::map<std::string, int> reasons;
        for (std::size_t i = 0; i < res.size(); ++i) {
            if (verbose) {
                const Eigen::Matrix4d ref = view_pairs[i].T_a_b.matrix();
                const double pe_t = (res[i].T_a_b.topRightCorner<3, 1>() - ref.topRightCorner<3, 1>()).norm();
                const double pe_r = Eigen::AngleAxisd(Eigen::Matrix3d(ref.topLeftCorner<3, 3>().transpose() *
                                                                    res[i].T_a_b.topLeftCorner<3, 3>()))
                                      .angle();
                std::printf(
                    "  %s %s: %s (%s) overlap %.2f e_t %.2f e_r %.1f kp %d/%d corr %d groups %d group %d inl %d "
                    "icp_in %.2f t %.2f s (desc %.2f, group %.2f, icp %.2f)\n",
                    view_pairs[i].id_a.c_str(), view_pairs[i].id_b.c_str(),
                    to_string(res[i].status), res[i].reason.c_str(), view_pairs[i].overlap, pe_t,
                    pe_r * 180 / M_PI, res[i].keypoints_a,
                    res[i].keypoints_b, res[i].correspondences, res[i].groups, res[i].group_size,
                    res[i].ransac_inliers, res[i].icp_inlier_fraction, res[i].duration_s,
                    res[i].descriptor_s, res[i].grouping_s, res[i].icp_s);
            }
            if (res[i].status == MatchStatus::kNoMatch || res[i].status == MatchStatus::kFailed)
                ++reasons[res[i].reason.substr(0, 40)];
            no_match += res[i].status == MatchStatus::kNoMatch;
            if (!res[i].matched) continue;
            ++m;
            m_overlap += view_pairs[i].overlap > 0.1;
            const Eigen::Matrix4d ref = view_pairs[i].T_a_b.matrix();
            const double e_t =
                (res[i].T_a_b.topRightCorner<3, 1>() - ref.topRightCorner<3, 1>()).norm();
            const Eigen::Matrix3d dR =
                ref.topLeftCorner<3, 3>().transpose() * res[i].T_a_b.topLeftCorner<3, 3>();
            const double e_r = Eigen::AngleAxisd(dR).angle();
            et.push_back(e_t);
            er.push_back(e_r);
            const double d = sizes[static_cast<std::size_t>(pairs[i].second)];
            sum_r += eps_t(std::max(e_t, 2.0 * d * std::sin(e_r / 2.0)));
        }
        const double eps = m > 0 ? std::max(0.0, sum_r / m) : 0.0;
        const double v = m / (m_star / 9.0 + m);
        const double p = 0.5 * v + 0.5 * eps;
        std::printf(
            "%s:\n  m %d (%d on overlapping pairs), no match %d, failed %d, timeouts %d; "
            "p %.4f (v %.3f, eps %.3f, e* %.2f, m* %.0f)\n",
            label, m, m_overlap, no_match, st.failed, st.timeouts, p, v, eps, e_star, m_star);
        std::printf("  e_t median %.3f m, p90 %.3f m; e_r median %.2f deg, p90 %.2f deg\n",
                    percentile(et, 0.5), percentile(et, 0.9), percentile(er, 0.5) * 180 / M_PI,
                    percentile(er, 0.9) * 180 / M_PI);
        std::printf(
            "  wall %.2f s: features %.2f s (%d submaps, %llu computed, %.2f submaps/s), "
            "pairs %.2f s (%.1f pairs/s, descriptor neighbour lists cached for %llu)\n",
            wall, st.feature_wall_s, st.submaps, static_cast<unsigned long long>(st.cache_misses),
            st.cache_misses ? st.cache_misses / st.feature_wall_s : 0.0, st.pair_wall_s,
            st.pairs / st.pair_wall_s, static_cast<unsigned long long>(st.neighbour_hits));
        for (const auto& [r, c] : reasons) std::printf("  reason x%d: %s\n", c, r.c_str());
        return wall;
    };
    const MatcherParams params = from_named_values(parse_kv(params_s));
    if (verbose >= 2) {
        // Diagnosis of the first pairs: do correct correspondences exist, do they vote together?
        for (std::size_t i = 0; i < std::min<std::size_t>(pairs.size(), 4); ++i) {
            const auto fa =
                matcher.features(submaps[static_cast<std::size_t>(pairs[i].first)], params);
            const auto fb =
                matcher.features(submaps[static_cast<std::size_t>(pairs[i].second)], params);
            if (fa->status != FeatureStatus::kOk || fb->status != FeatureStatus::kOk) continue;
            const auto corrs =
                match_descriptors(fa->descriptors, fb->descriptors, params.n_C, params.t_C);
            const Eigen::Matrix4f T = view_pairs[i].T_a_b.matrix().cast<float>();
            const Eigen::Matrix3f R = T.topLeftCorner<3, 3>();
            const Eigen::Vector3f true_vote = (T * fb->keypoint_centroid.homogeneous()).head<3>();
            int good = 0, lrf_ok = 0;
            double vote_err = 0;
            for (const auto& c : corrs) {
                const Eigen::Vector3f pb = (T * fb->keypoints.col(c.b).homogeneous()).head<3>();
                if ((pb - fa->keypoints.col(c.a)).norm() >= params.v_K) continue;
                ++good;
                const Eigen::Matrix3f Ra = fa->lrfs[static_cast<std::size_t>(c.a)];
                const Eigen::Matrix3f Rb = fb->lrfs[static_cast<std::size_t>(c.b)] * R.transpose();
                lrf_ok += Eigen::AngleAxisf(Eigen::Matrix3f(Ra * Rb.transpose())).angle() < 0.2f;
                const Eigen::Vector3f vote =
                    fa->keypoints.col(c.a) +
                    Ra.transpose() * (fb->lrfs[static_cast<std::size_t>(c.b)] *
                                      (fb->keypoint_centroid - fb->keypoints.col(c.b)));
                vote_err += (vote - true_vote).norm();
            }
            // Does the reference align the clouds? Fraction of sampled b points within 0.1 m of a.
            {
                const auto& ca = submaps[static_cast<std::size_t>(pairs[i].first)].cloud;
                const auto& cb = submaps[static_cast<std::size_t>(pairs[i].second)].cloud;
                auto frac = [&](const Eigen::Matrix4f& TT) {
                    int near = 0, n = 0;
                    for (std::size_t q = 0; q < cb.size(); q += 97, ++n) {
                        const Eigen::Vector3f pb =
                            (TT * Eigen::Vector4f(cb[q].x, cb[q].y, cb[q].z, 1.f)).head<3>();
                        for (std::size_t r = 0; r < ca.size(); r += 3)
                            if ((Eigen::Vector3f(ca[r].x, ca[r].y, ca[r].z) - pb).norm() < 0.1f) {
                                ++near;
                                break;
                            }
                    }
                    return n ? double(near) / n : 0.0;
                };
                std::printf(
                    "diag cloud overlap within 0.1 m: reference %.2f, identity %.2f, inverse "
                    "%.2f\n",
                    frac(T), frac(Eigen::Matrix4f::Identity()), frac(T.inverse()));
            }
            // Keypoints of b that have a keypoint of a within v_K under the reference.
            int kp_overlap = 0;
            for (int j = 0; j < fb->num_keypoints(); ++j) {
                const Eigen::Vector3f pb = (T * fb->keypoints.col(j).homogeneous()).head<3>();
                for (int k = 0; k < fa->num_keypoints(); ++k)
                    if ((pb - fa->keypoints.col(k)).norm() < params.v_K) {
                        ++kp_overlap;
                        break;
                    }
            }
            std::printf(
                "diag %s-%s: kp %d/%d (%d of b near a keypoint), corr %zu, correct %d, "
                "LRF within 11 deg %d, mean vote error %.3f m, overlap %.2f\n",
                view_pairs[i].id_a.c_str(), view_pairs[i].id_b.c_str(), fa->num_keypoints(),
                fb->num_keypoints(), kp_overlap, corrs.size(), good, lrf_ok,
                good ? vote_err / good : 0.0, view_pairs[i].overlap);
        }
    }
    auto pair_kv = to_named_values(params);
    for (const auto& [k, v] : parse_kv(pair_params_s)) pair_kv[k] = v;
    const MatcherParams changed = from_named_values(pair_kv);
    const double first = evaluate("first evaluation (cold cache)", params);
    const double second = evaluate("pair-stage parameters changed (warm cache)", changed);
    std::printf("re-evaluation / first: %.1f %%\n", 100.0 * second / first);
    return 0;
}
