#include "matcher/matcher_params.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
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


std::string set_matcher_setting(MatcherSettings& s, const std::string& key, const std::string& value) {
    auto number = [&](double lo, double hi, double& out) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(value.c_str(), &end);
        if (value.empty() || end == value.c_str() || *end != '\0' || !std::isfinite(v) || v < lo || v > hi) {
            std::ostringstream msg;
            msg << "matcher setting " << key << ": '" << value << "' is not a number in [" << lo << ", " << hi << "]";
            return msg.str();
        }
        out = v;
        return "";
    };
    auto real = [&](double& field, double lo, double hi) { return number(lo, hi, field); };
    auto integer = [&](int& field, double lo, double hi) {
        double v = 0;
        auto err = number(lo, hi, v);
        if (err.empty() && v != std::floor(v)) err = "matcher setting " + key + ": '" + value + "' is not an integer";
        if (err.empty()) field = static_cast<int>(v);
        return err;
    };
    auto boolean = [&](bool& field) -> std::string {
        if (value == "true" || value == "1") field = true;
        else if (value == "false" || value == "0") field = false;
        else return "matcher setting " + key + ": '" + value + "' is not true or false";
        return "";
    };
    const std::map<std::string, std::function<std::string()>> table{
        {"outlier_removal", [&] { return boolean(s.outlier_removal); }},
        {"outlier_mean_k", [&] { return integer(s.outlier_mean_k, 1, 1000); }},
        {"outlier_stddev_mul", [&] { return real(s.outlier_stddev_mul, 0.01, 100); }},
        {"surface_points_per_radius", [&] { return real(s.surface_points_per_radius, 1, 1000); }},
        {"unknown_samples_per_diameter", [&] { return real(s.unknown_samples_per_diameter, 2, 256); }},
        {"collinear_inlier_fraction", [&] { return real(s.collinear_inlier_fraction, 0, 1); }},
        {"line_threshold_m", [&] { return real(s.line_threshold_m, 0, 100); }},
        {"ransac_iterations", [&] { return integer(s.ransac_iterations, 1, 1e7); }},
        {"ransac_inlier_threshold_m", [&] { return real(s.ransac_inlier_threshold_m, 0, 100); }},
        {"icp_enabled", [&] { return boolean(s.icp_enabled); }},
        {"icp_max_iterations", [&] { return integer(s.icp_max_iterations, 1, 1000); }},
        {"icp_max_correspondence_m", [&] { return real(s.icp_max_correspondence_m, 0, 100); }},
        {"icp_voxel_m", [&] { return real(s.icp_voxel_m, 0, 10); }},
        {"icp_point_to_plane", [&] { return boolean(s.icp_point_to_plane); }},
        {"icp_source_voxel_factor", [&] { return real(s.icp_source_voxel_factor, 0, 100); }},
        {"max_roll_pitch_rad", [&] { return real(s.max_roll_pitch_rad, 0, M_PI); }},
        {"min_icp_inlier_fraction", [&] { return real(s.min_icp_inlier_fraction, 0, 1); }},
        {"min_ransac_inliers", [&] { return integer(s.min_ransac_inliers, 0, 1e6); }},
        {"consensus_from_n_TF", [&] { return boolean(s.consensus_from_n_TF); }},
        {"ransac_threshold_from", [&]() -> std::string {
             if (value == "v_K") s.ransac_threshold_from = MatcherSettings::ThresholdFrom::kVK;
             else if (value == "v_TF") s.ransac_threshold_from = MatcherSettings::ThresholdFrom::kVTF;
             else return "matcher setting " + key + ": '" + value + "' is not v_K or v_TF";
             return "";
         }},
        {"lrf_method", [&]() -> std::string {
             if (value == "shot") s.lrf_method = LrfMethod::kShot;
             else if (value == "board") s.lrf_method = LrfMethod::kBoard;
             else return "matcher setting " + key + ": '" + value + "' is not shot or board";
             return "";
         }},
        {"viewpoint_x", [&] { return real(s.viewpoint_x, -1e6, 1e6); }},
        {"viewpoint_y", [&] { return real(s.viewpoint_y, -1e6, 1e6); }},
        {"viewpoint_z", [&] { return real(s.viewpoint_z, -1e6, 1e6); }},
        {"min_points", [&] { return integer(s.min_points, 0, 1e9); }},
        {"min_keypoints", [&] { return integer(s.min_keypoints, 0, 1e9); }},
        {"seed", [&] {
             double v = 0;
             auto err = number(0, 9.007199254740992e15, v);
             if (err.empty()) s.seed = static_cast<std::uint64_t>(v);
             return err;
         }},
    };
    const auto it = table.find(key);
    if (it == table.end()) {
        std::string known;
        for (const auto& [k, f] : table) known += (known.empty() ? "" : ", ") + k;
        return "unknown matcher setting '" + key + "' (known: " + known + ")";
    }
    return it->second();
}

std::string set_matcher_settings(MatcherSettings& s, const std::vector<std::string>& key_values) {
    for (const auto& kv : key_values) {
        const auto eq = kv.find('=');
        if (eq == std::string::npos) return "--matcher " + kv + ": expected KEY=VALUE";
        if (auto err = set_matcher_setting(s, kv.substr(0, eq), kv.substr(eq + 1)); !err.empty()) {
            return "--matcher " + kv + ": " + err;
        }
    }
    return "";
}

std::vector<std::string> matcher_setting_names() {
    // The table lives in set_matcher_setting (its lambdas bind the field to set); its error for
    // an unknown key lists every key, so that list is the one source.
    MatcherSettings s;
    const std::string error = set_matcher_setting(s, "", "");
    const std::string marker = "(known: ";
    const auto begin = error.find(marker) + marker.size();
    std::vector<std::string> out;
    std::string list = error.substr(begin, error.size() - begin - 1);
    for (std::size_t pos = 0; pos < list.size();) {
        const auto comma = list.find(", ", pos);
        out.push_back(list.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos));
        if (comma == std::string::npos) break;
        pos = comma + 2;
    }
    return out;
}

}  // namespace maptune::matcher
