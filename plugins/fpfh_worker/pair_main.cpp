// The FPFH + RANSAC + GICP matcher on one pair of real clouds, with its error against a
// reference transform (the real-pair table of BENCHMARKS.md, issue 13):
//
//   maptune_fpfh_pair --target A --source B (--ref-matrix F | --bunny-conf F | --car-list F)
//                     [--space configs/spaces/fpfh_gicp.yaml --params-file best_params.yaml]
//                     [--params voxel_m=..,feature_scale=..,...]
//
// --params-file reads a set (a run's best_params.yaml) checked against --space; --params then
// overrides single values without the space's bounds — a tuned set moves to another data
// scale by voxel_m alone (the other radii are in voxels).
// T_ref is the pose of the source in the target's frame (p_target = T_ref p_source). The
// readers are libs/matcher's (PLY, CSV, bun.conf, carCloudList.csv, 4x4 text).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <sstream>
#include <string>

#include "fpfh_matcher.hpp"
#include "matcher/cloud_io.hpp"
#include "measure/measure.hpp"
#include "params/parameter_set.hpp"
#include "params/parameter_space.hpp"

namespace io = maptune::matcher::io;

namespace {

// "k=v,k=v" over `values`; an unknown key or a bad number is an error naming it.
bool apply(const std::string& text, std::map<std::string, double> values, maptune::fpfh::Params& p,
           std::string* error) {
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ',')) {
        if (item.empty()) continue;
        const auto eq = item.find('=');
        const std::string key = item.substr(0, eq);
        if (eq == std::string::npos || !values.count(key)) {
            *error = "--params: '" + item + "' is not KEY=VALUE with a key of the fpfh_gicp space";
            return false;
        }
        try {
            std::size_t used = 0;
            values[key] = std::stod(item.substr(eq + 1), &used);
            if (used != item.size() - eq - 1) throw std::invalid_argument("trailing text");
        } catch (const std::exception&) {
            *error = "--params: '" + item + "': the value is not a number";
            return false;
        }
    }
    try {
        p = maptune::fpfh::params_from(values);
    } catch (const std::exception& e) {
        *error = std::string("--params: ") + e.what();
        return false;
    }
    return true;
}

}  // namespace

int main(int argc, char** argv) {
    std::string target, source, ref_matrix, bunny_conf, car_list, params_text, space_file, params_file;
    for (int i = 1; i < argc; ++i) {
        const std::string k = argv[i];
        if (k == "--help" || k == "-h") {
            std::cout << "usage: maptune_fpfh_pair --target A --source B (--ref-matrix F | --bunny-conf F | "
                         "--car-list F) [--space SPACE.yaml [--params-file SET.yaml]] [--params KEY=VALUE,...]\n";
            return 0;
        }
        if (i + 1 >= argc) {
            std::cerr << "error: " << k << " needs a value\n";
            return 2;
        }
        const std::string v = argv[++i];
        if (k == "--target") target = v;
        else if (k == "--source") source = v;
        else if (k == "--ref-matrix") ref_matrix = v;
        else if (k == "--bunny-conf") bunny_conf = v;
        else if (k == "--car-list") car_list = v;
        else if (k == "--params") params_text = v;
        else if (k == "--space") space_file = v;
        else if (k == "--params-file") params_file = v;
        else {
            std::cerr << "error: unknown option " << k << "\n";
            return 2;
        }
    }
    if (target.empty() || source.empty()) {
        std::cerr << "error: --target and --source are required (--help)\n";
        return 2;
    }
    const maptune::fpfh::Params defaults;
    std::map<std::string, double> values = {
        {"voxel_m", defaults.voxel_m},           {"normal_scale", defaults.normal_scale},
        {"feature_scale", defaults.feature_scale}, {"n_corr", defaults.n_corr},
        {"similarity", defaults.similarity},     {"inlier_scale", defaults.inlier_scale},
        {"gicp_scale", defaults.gicp_scale},     {"min_overlap", defaults.min_overlap}};
    try {
        if (!params_file.empty() && space_file.empty()) throw std::invalid_argument("--params-file needs --space");
        if (!space_file.empty()) {
            const auto space = maptune::params::ParameterSpace::load(space_file);
            const auto set = params_file.empty() ? space.defaults()
                                                 : maptune::params::load_parameter_set(params_file, space);
            for (const auto& [k, v] : set) values[k] = v;
        }
    } catch (const std::exception& e) {
        std::cerr << "error: " << e.what() << "\n";
        return 2;
    }
    maptune::fpfh::Params params;
    std::string error;
    if (!apply(params_text, values, params, &error)) {
        std::cerr << "error: " << error << "\n";
        return 2;
    }
    const auto base = [](const std::string& p) { return p.substr(p.find_last_of('/') + 1); };
    Eigen::Matrix4d T_ref = Eigen::Matrix4d::Identity();
    bool have_ref = false;
    if (!ref_matrix.empty()) {
        if (!io::read_matrix4(ref_matrix, T_ref)) {
            std::cerr << "error: cannot read a 4x4 matrix from " << ref_matrix << "\n";
            return 1;
        }
        have_ref = true;
    } else if (!bunny_conf.empty()) {
        const auto poses = io::read_bunny_conf(bunny_conf);
        if (!poses.count(base(target)) || !poses.count(base(source))) {
            std::cerr << "error: " << bunny_conf << " has no pose for " << base(target) << " or " << base(source) << "\n";
            return 1;
        }
        T_ref = (poses.at(base(target)).inverse() * poses.at(base(source))).matrix();
        have_ref = true;
    } else if (!car_list.empty()) {
        const auto list = io::read_car_cloud_list(car_list);  // rows: target, source
        if (list.size() < 2) {
            std::cerr << "error: " << car_list << " has fewer than 2 poses\n";
            return 1;
        }
        T_ref = list[0].inverse() * list[1];
        have_ref = true;
    }
    std::vector<Eigen::Vector3f> pa, pb;
    if (!io::read_scan_pair(target, source, pa, pb, error)) {
        std::cerr << "error: " << error << "\n";
        return 1;
    }
    // The bunny's PLY files mark missing range samples as (0,0,0).
    const auto drop_origin = [](std::vector<Eigen::Vector3f> v) {
        v.erase(std::remove_if(v.begin(), v.end(), [](const auto& p) { return p.squaredNorm() == 0; }), v.end());
        return v;
    };
    const auto fa = maptune::fpfh::prepare(drop_origin(pa), params);
    const auto fb = maptune::fpfh::prepare(drop_origin(pb), params);
    std::printf("target %s: %zu points -> %d, %.3f s; source %s: %zu points -> %d, %.3f s\n", base(target).c_str(),
                pa.size(), fa.points, fa.seconds, base(source).c_str(), pb.size(), fb.points, fb.seconds);
    if (!fa.cloud || !fb.cloud) {
        std::printf("no features: %s\n", (fa.cloud ? fb.reason : fa.reason).c_str());
        return 3;
    }
    const maptune::fpfh::Settings settings;
    const auto r = maptune::fpfh::register_pair(*fa.cloud, *fb.cloud, params, settings, 1);
    std::printf("pair: %s%s%s, correspondences %d, RANSAC inliers %d, overlap %.3f, pair %.3f s, total %.3f s\n",
                r.matched ? "match" : "no match", r.reason.empty() ? "" : " - ", r.reason.c_str(),
                r.correspondences, r.ransac_inliers, r.overlap, r.seconds, fa.seconds + fb.seconds + r.seconds);
    if (have_ref) {
        const auto e = maptune::measure::pair_error(Eigen::Isometry3d(T_ref), Eigen::Isometry3d(r.T_a_b), 0);
        std::printf("error: rotation %.3f deg, translation %.4f m\n", e.e_r * 180.0 / M_PI, e.e_t);
    }
    return r.matched ? 0 : 3;
}
