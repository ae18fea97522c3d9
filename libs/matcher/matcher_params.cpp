#include "matcher/matcher_params.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace maptune::matcher {

MatcherParams from_named_values(const std::map<std::string, double>& values) {
    MatcherParams p;
    auto get = [&](const char* key, double fallback) {
        auto it = values.find(key);
        return it == values.end() ? fallback : it->second;
    };
    p.r_N = get("r_N", p.r_N);
    p.v_K = get("v_K", p.v_K);
    p.t_K = get("t_K", p.t_K);
    p.r_D = get("r_D", p.r_D);
    p.n_C = static_cast<int>(std::lround(get("n_C", p.n_C)));
    p.t_C = get("t_C", p.t_C);
    p.r_LRF = get("r_LRF", p.r_LRF);
    p.v_TF = get("v_TF", p.v_TF);
    p.n_TF = static_cast<int>(std::lround(get("n_TF", p.n_TF)));
    return p;
}

std::map<std::string, double> to_named_values(const MatcherParams& p) {
    return {{"r_N", p.r_N},     {"v_K", p.v_K},         {"t_K", p.t_K},
            {"r_D", p.r_D},     {"n_C", double(p.n_C)}, {"t_C", p.t_C},
            {"r_LRF", p.r_LRF}, {"v_TF", p.v_TF},       {"n_TF", double(p.n_TF)}};
}

int clamp_to_bounds(MatcherParams& p) {
    int clamped = 0;
    auto clamp = [&](double& v, double lo, double hi) {
        const double c = std::isnan(v) ? lo : std::clamp(v, lo, hi);
        if (c != v) ++clamped;
        v = c;
    };
    auto clamp_int = [&](int& v, int lo, int hi) {
        const int c = std::clamp(v, lo, hi);
        if (c != v) ++clamped;
        v = c;
    };
    clamp(p.r_N, 0.1, 2.0);
    clamp(p.v_K, 0.05, 0.5);
    clamp(p.t_K, 0.0, 1.0);
    clamp(p.r_D, 0.1, 2.0);
    clamp_int(p.n_C, 1, 10);
    clamp(p.t_C, 0.0, 1.0);
    clamp(p.r_LRF, 0.1, 1.0);
    clamp(p.v_TF, 0.1, 1.0);
    clamp_int(p.n_TF, 3, 300);
    return clamped;
}

std::string feature_settings_fingerprint(const MatcherSettings& s) {
    std::ostringstream os;
    os << s.outlier_removal << '/' << s.outlier_mean_k << '/' << s.outlier_stddev_mul << '/'
       << s.surface_points_per_radius << '/' << s.unknown_samples_per_diameter << '/'
       << s.viewpoint_x << ',' << s.viewpoint_y << ',' << s.viewpoint_z << '/' << s.icp_voxel_m
       << '/' << s.min_points << '/' << s.min_keypoints << '/' << static_cast<int>(s.lrf_method)
       << '/' << s.icp_point_to_plane << '/' << s.icp_source_voxel_factor;
    return os.str();
}

}  // namespace maptune::matcher
