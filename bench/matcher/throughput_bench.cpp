// Throughput of the two stages on synthetic lab-like submaps (ground with coloured rocks,
// obstacle points on the rocks, no octree): submaps/s of the per-submap stage, pairs/s of
// the pair stage on the complete view, and the re-evaluation with only pair-stage parameters
// changed (features from the cache).
//
//   matcher_throughput [--submaps N] [--threads T] [--params k=v,...]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "matcher/matcher.hpp"
#include "test_scene.hpp"

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
}  // namespace

int main(int argc, char** argv) {
    int n = 12, threads = 0;
    std::string params_s;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string k = argv[i], v = argv[i + 1];
        if (k == "--submaps")
            n = std::atoi(v.c_str());
        else if (k == "--threads")
            threads = std::atoi(v.c_str());
        else if (k == "--params")
            params_s = v;
    }
    // A 6 + 2n metre strip of rocks; submap i covers x in [2i, 2i + 6] (6 x 6 m), with its
    // own origin and yaw, so neighbours overlap by 4 m and pairs more than 2 apart do not.
    const float extent = 6.f;  // y extent [m]
    std::vector<maptune::dataset::Submap> submaps;
    std::size_t points = 0;
    for (int i = 0; i < n; ++i) {
        Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
        T.linear() = Eigen::AngleAxisf(0.3f * static_cast<float>(i), Eigen::Vector3f::UnitZ())
                         .toRotationMatrix();
        T.translation() = Eigen::Vector3f(2.f * static_cast<float>(i) + 3.f, 3.f, 0.f);
        submaps.push_back(maptune::matcher::test::make_scene_submap(
            "sim/submap" + std::to_string(i), 2.f * static_cast<float>(i),
            2.f * static_cast<float>(i) + 6.f, 2.f * static_cast<float>(n) + 6.f, T, 11, 0.05f,
            extent));
        points += submaps.back().cloud.size();
    }
    std::vector<std::pair<int, int>> pairs;
    int overlapping = 0;
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) {
            pairs.emplace_back(i, j);
            overlapping += (j - i) <= 2;
        }
    MatcherSettings settings;
    settings.threads = threads;
    Matcher m(settings);
    MatcherParams p = from_named_values(parse_kv(params_s));
    std::printf("%d submaps (%.0f points each on average), %zu pairs (%d overlapping by >= 2 m)\n",
                n, double(points) / n, pairs.size(), overlapping);

    auto run = [&](const char* label, const MatcherParams& params) {
        EvaluationStats st;
        const auto t0 = std::chrono::steady_clock::now();
        const auto res = m.match_pairs(submaps, pairs, params, &st);
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        int correct = 0;
        for (std::size_t k = 0; k < res.size(); ++k) {
            if (!res[k].matched) continue;
            const auto& a = submaps[static_cast<std::size_t>(pairs[k].first)];
            const auto& b = submaps[static_cast<std::size_t>(pairs[k].second)];
            const Eigen::Matrix4d ref =
                (a.T_world_submap_gt.inverse() * b.T_world_submap_gt).matrix();
            const Eigen::Matrix3d dR =
                ref.topLeftCorner<3, 3>().transpose() * res[k].T_a_b.topLeftCorner<3, 3>();
            const double e_t =
                (ref.topRightCorner<3, 1>() - res[k].T_a_b.topRightCorner<3, 1>()).norm();
            correct += e_t < 0.2 && Eigen::AngleAxisd(dR).angle() < 2.0 * M_PI / 180.0;
        }
        std::printf(
            "%s: wall %.2f s; features %.2f s (%d submaps, %.2f submaps/s, %llu misses, "
            "%llu hits); pairs %.2f s (%.1f pairs/s); matched %d (correct %d), failed %d, "
            "timeouts %d\n",
            label, wall, st.feature_wall_s, st.submaps,
            st.cache_misses ? st.submaps / st.feature_wall_s : 0.0,
            static_cast<unsigned long long>(st.cache_misses),
            static_cast<unsigned long long>(st.cache_hits), st.pair_wall_s,
            st.pairs / st.pair_wall_s, st.matched, correct, st.failed, st.timeouts);
        return wall;
    };
    const double first = run("baseline (cold cache)", p);
    MatcherParams q = p;
    q.n_C = 5, q.t_C = 0.7, q.v_TF = 0.3, q.n_TF = 12;
    const double second = run("pair-stage params changed (warm cache)", q);
    std::printf("re-evaluation / first evaluation: %.1f %%\n", 100.0 * second / first);
    return 0;
}
