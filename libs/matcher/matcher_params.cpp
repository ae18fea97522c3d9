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

namespace {

std::string number_text(double v) {
    std::ostringstream os;
    os.precision(17);  // round-trips every double
    os << v;
    return os.str();
}

// Parses `value` as a finite number in [lo, hi]; the error names the setting and the text.
std::string parse_number(const std::string& key, const std::string& value, double lo, double hi, double& out) {
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (value.empty() || end == value.c_str() || *end != '\0' || !std::isfinite(v) || v < lo || v > hi) {
        std::ostringstream msg;
        msg << "matcher setting " << key << ": '" << value << "' is not a number in [" << lo << ", " << hi << "]";
        return msg.str();
    }
    out = v;
    return "";
}

SettingField real(const char* name, bool per_submap, double MatcherSettings::*field, double lo, double hi) {
    return {name, per_submap,
            [=](MatcherSettings& s, const std::string& v) { return parse_number(name, v, lo, hi, s.*field); },
            [=](const MatcherSettings& s) { return number_text(s.*field); }};
}

template <class Int>
SettingField integer(const char* name, bool per_submap, Int MatcherSettings::*field, double lo, double hi) {
    return {name, per_submap,
            [=](MatcherSettings& s, const std::string& v) {
                double x = 0;
                auto err = parse_number(name, v, lo, hi, x);
                if (err.empty() && x != std::floor(x)) err = "matcher setting " + std::string(name) + ": '" + v + "' is not an integer";
                if (err.empty()) s.*field = static_cast<Int>(x);
                return err;
            },
            [=](const MatcherSettings& s) { return std::to_string(s.*field); }};
}

SettingField boolean(const char* name, bool per_submap, bool MatcherSettings::*field) {
    return {name, per_submap,
            [=](MatcherSettings& s, const std::string& v) -> std::string {
                if (v == "true" || v == "1") s.*field = true;
                else if (v == "false" || v == "0") s.*field = false;
                else return "matcher setting " + std::string(name) + ": '" + v + "' is not true or false";
                return "";
            },
            [=](const MatcherSettings& s) -> std::string { return s.*field ? "true" : "false"; }};
}

template <class Enum>
SettingField choice(const char* name, bool per_submap, Enum MatcherSettings::*field,
                    std::vector<std::pair<std::string, Enum>> options) {
    return {name, per_submap,
            [=](MatcherSettings& s, const std::string& v) -> std::string {
                std::string known;
                for (const auto& [text, e] : options) {
                    if (v == text) {
                        s.*field = e;
                        return "";
                    }
                    known += (known.empty() ? "" : " or ") + text;
                }
                return "matcher setting " + std::string(name) + ": '" + v + "' is not " + known;
            },
            [=](const MatcherSettings& s) {
                for (const auto& [text, e] : options)
                    if (s.*field == e) return text;
                return std::string("?");
            }};
}

SettingField since_revision_4(SettingField f) {
    f.versioned_at_default = false;
    return f;
}

}  // namespace

bool in_version(const SettingField& f, const MatcherSettings& s) {
    static const MatcherSettings defaults;
    return f.versioned_at_default || f.get(s) != f.get(defaults);
}

const std::vector<SettingField>& setting_fields() {
    using S = MatcherSettings;
    static const std::vector<SettingField> fields{
        boolean("outlier_removal", true, &S::outlier_removal),
        integer("outlier_mean_k", true, &S::outlier_mean_k, 1, 1000),
        real("outlier_stddev_mul", true, &S::outlier_stddev_mul, 0.01, 100),
        real("surface_points_per_radius", true, &S::surface_points_per_radius, 1, 1000),
        choice("lrf_method", true, &S::lrf_method, {{"shot", LrfMethod::kShot}, {"board", LrfMethod::kBoard}}),
        real("unknown_samples_per_diameter", true, &S::unknown_samples_per_diameter, 2, 256),
        real("viewpoint_x", true, &S::viewpoint_x, -1e6, 1e6),
        real("viewpoint_y", true, &S::viewpoint_y, -1e6, 1e6),
        real("viewpoint_z", true, &S::viewpoint_z, -1e6, 1e6),
        real("collinear_inlier_fraction", false, &S::collinear_inlier_fraction, 0, 1),
        real("line_threshold_m", false, &S::line_threshold_m, 0, 100),
        integer("line_ransac_iterations", false, &S::line_ransac_iterations, 1, 1e7),
        integer("ransac_iterations", false, &S::ransac_iterations, 1, 1e7),
        real("ransac_inlier_threshold_m", false, &S::ransac_inlier_threshold_m, 0, 100),
        choice("ransac_threshold_from", false, &S::ransac_threshold_from,
               {{"v_K", S::ThresholdFrom::kVK}, {"v_TF", S::ThresholdFrom::kVTF}}),
        integer("icp_max_iterations", false, &S::icp_max_iterations, 1, 1000),
        real("icp_max_correspondence_m", false, &S::icp_max_correspondence_m, 0, 100),
        // The ICP cloud is built per submap with the features, hence per-submap.
        real("icp_voxel_m", true, &S::icp_voxel_m, 0, 10),
        boolean("icp_enabled", false, &S::icp_enabled),
        boolean("icp_point_to_plane", true, &S::icp_point_to_plane),
        real("icp_source_voxel_factor", true, &S::icp_source_voxel_factor, 0, 100),
        real("max_roll_pitch_rad", false, &S::max_roll_pitch_rad, 0, M_PI),
        real("min_icp_inlier_fraction", false, &S::min_icp_inlier_fraction, 0, 1),
        integer("min_ransac_inliers", false, &S::min_ransac_inliers, 0, 1e6),
        boolean("consensus_from_n_TF", false, &S::consensus_from_n_TF),
        integer("min_points", true, &S::min_points, 0, 1e9),
        integer("min_keypoints", true, &S::min_keypoints, 0, 1e9),
        // A timed-out submap or pair is never cached or stored, so the limits are not per-submap.
        real("pair_time_limit_s", false, &S::pair_time_limit_s, 0.001, 1e7),
        real("submap_time_limit_s", false, &S::submap_time_limit_s, 0.001, 1e7),
        real("total_time_limit_s", false, &S::total_time_limit_s, 0.001, 1e7),
        integer("seed", false, &S::seed, 0, 9.007199254740992e15),
        // Added after revision 4 (see SettingField::versioned_at_default). The check needs the
        // submaps' OctoMaps, which features keep only when it is on: hence per-submap.
        since_revision_4(real("max_free_space_fraction", true, &S::max_free_space_fraction, 0, 1)),
        since_revision_4(real("free_space_margin_m", false, &S::free_space_margin_m, 0, 10)),
    };
    return fields;
}

std::string feature_settings_fingerprint(const MatcherSettings& s) {
    std::string out;
    for (const auto& f : setting_fields())
        if (f.per_submap && in_version(f, s)) out += (out.empty() ? "" : "/") + f.name + "=" + f.get(s);
    return out;
}

std::vector<std::string> setting_texts(const MatcherSettings& s) {
    std::vector<std::string> out;
    for (const auto& f : setting_fields()) out.push_back(f.name + "=" + f.get(s));
    return out;
}

std::string set_matcher_setting(MatcherSettings& s, const std::string& key, const std::string& value) {
    for (const auto& f : setting_fields())
        if (f.name == key) return f.set(s, value);
    std::string known;
    for (const auto& name : matcher_setting_names()) known += (known.empty() ? "" : ", ") + name;
    return "unknown matcher setting '" + key + "' (known: " + known + ")";
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
    std::vector<std::string> out;
    for (const auto& f : setting_fields()) out.push_back(f.name);
    std::sort(out.begin(), out.end());
    return out;
}

}  // namespace maptune::matcher
