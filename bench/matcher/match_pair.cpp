// Runs the matcher on one pair of real clouds and reports the error against a reference,
// with the intermediate counts (correct correspondences, group purity) for diagnosis.
//
//   matcher_pair --target A --source B (--ref-matrix F | --bunny-conf F | --car-list F)
//                [--params r_N=..,v_K=..,...] [--set key=value,...] [--repeat N]
// T_ref is the pose of the source in the target's frame (p_target = T_ref p_source).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <sstream>
#include <string>

#include "matcher/cloud_io.hpp"
#include "matcher/descriptor_matching.hpp"
#include "matcher/grouping.hpp"
#include "matcher/matcher.hpp"

using namespace maptune::matcher;

namespace {

std::map<std::string, double> parse_kv(const std::string& s) {
    std::map<std::string, double> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ',')) {
        const auto eq = item.find('=');
        if (eq != std::string::npos) out[item.substr(0, eq)] = std::atof(item.c_str() + eq + 1);
    }
    return out;
}

void apply_settings(MatcherSettings& s, const std::map<std::string, double>& kv) {
    for (const auto& [k, v] : kv) {
        if (k == "ransac_thr")
            s.ransac_inlier_threshold_m = v;
        else if (k == "icp_corr")
            s.icp_max_correspondence_m = v;
        else if (k == "icp_iter")
            s.icp_max_iterations = static_cast<int>(v);
        else if (k == "icp_voxel")
            s.icp_voxel_m = v;
        else if (k == "line_thr")
            s.line_threshold_m = v;
        else if (k == "threads")
            s.threads = static_cast<int>(v);
        else if (k == "sor")
            s.outlier_removal = v != 0;
        else if (k == "surface_k")
            s.surface_points_per_radius = v;
        else if (k == "seed")
            s.seed = static_cast<std::uint64_t>(v);
        else if (k == "icp")
            s.icp_enabled = v != 0;
        else if (k == "board")
            s.lrf_method = v != 0 ? LrfMethod::kBoard : LrfMethod::kShot;
        else
            std::cerr << "unknown setting " << k << "\n";
    }
}

void errors(const Eigen::Matrix4d& T, const Eigen::Matrix4d& ref, double& rot_deg, double& trans) {
    const Eigen::Matrix3d dR = ref.topLeftCorner<3, 3>().transpose() * T.topLeftCorner<3, 3>();
    rot_deg = Eigen::AngleAxisd(dR).angle() * 180.0 / M_PI;
    trans = (T.topRightCorner<3, 1>() - ref.topRightCorner<3, 1>()).norm();
}

}  // namespace

int main(int argc, char** argv) {
    std::string target, source, ref_matrix, bunny_conf, car_list, params_s, set_s;
    int repeat = 1;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string k = argv[i], v = argv[i + 1];
        if (k == "--target")
            target = v;
        else if (k == "--source")
            source = v;
        else if (k == "--ref-matrix")
            ref_matrix = v;
        else if (k == "--bunny-conf")
            bunny_conf = v;
        else if (k == "--car-list")
            car_list = v;
        else if (k == "--params")
            params_s = v;
        else if (k == "--set")
            set_s = v;
        else if (k == "--repeat")
            repeat = std::atoi(v.c_str());
        else {
            std::cerr << "unknown option " << k << "\n";
            return 2;
        }
    }
    if (target.empty() || source.empty()) {
        std::cerr << "usage: matcher_pair --target A --source B (--ref-matrix F | --bunny-conf F "
                     "| --car-list F) [--params k=v,...] [--set k=v,...] [--repeat N]\n";
        return 2;
    }
    Eigen::Matrix4d T_ref = Eigen::Matrix4d::Identity();
    auto base = [](const std::string& p) { return p.substr(p.find_last_of('/') + 1); };
    if (!ref_matrix.empty() && !io::read_matrix4(ref_matrix, T_ref)) {
        std::cerr << "cannot read " << ref_matrix << "\n";
        return 1;
    }
    if (!bunny_conf.empty()) {
        const auto poses = io::read_bunny_conf(bunny_conf);
        T_ref = (poses.at(base(target)).inverse() * poses.at(base(source))).matrix();
    }
    if (!car_list.empty()) {
        const auto list = io::read_car_cloud_list(car_list);  // rows: 400, 401
        T_ref = list.at(0).inverse() * list.at(1);
    }
    std::vector<Eigen::Vector3f> pa, pb;
    std::string error;
    if (!io::read_scan_pair(target, source, pa, pb, error)) {
        std::cerr << "error: " << error << "\n";
        return 1;
    }
    const auto a = io::make_submap(base(target), pa), b = io::make_submap(base(source), pb);
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
    for (const auto& p : a.cloud) {
        lo = lo.cwiseMin(Eigen::Vector3f(p.x, p.y, p.z));
        hi = hi.cwiseMax(Eigen::Vector3f(p.x, p.y, p.z));
    }
    const double extent = (hi - lo).maxCoeff();
    MatcherParams params = from_named_values(parse_kv(params_s));
    MatcherSettings settings;
    apply_settings(settings, parse_kv(set_s));
    FeatureCacheOptions cache;
    cache.key_quantum = 1e-5;
    std::printf("target %s: %zu points, source %s: %zu points, extent %.3f m\n",
                base(target).c_str(), a.cloud.size(), base(source).c_str(), b.cloud.size(), extent);

    for (int rep = 0; rep < repeat; ++rep) {
        Matcher m(settings, cache);
        const auto t0 = std::chrono::steady_clock::now();
        const auto fa = m.features(a, params);
        const auto fb = m.features(b, params);
        const double t_feat =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        for (const auto* f : {fa.get(), fb.get()})
            std::printf(
                "features %s: status %d (%s) points %d->%d candidates %d voxel_kp %d kept %d "
                "invalid desc %d lrf %d normals %d, %.3f s\n",
                f->submap_id.c_str(), static_cast<int>(f->status), f->reason.c_str(), f->points_in,
                f->points_filtered, f->keypoint_candidates, f->keypoints_voxel, f->num_keypoints(),
                f->invalid_descriptors, f->invalid_lrfs, f->invalid_normals, f->duration_s);
        const auto t1 = std::chrono::steady_clock::now();
        const auto r = match_features(*fa, *fb, params, settings, Deadline::in(60),
                                      pair_seed(settings.seed, a.id, b.id));
        const double t_pair =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
        double rot = 0, trans = 0;
        errors(r.T_a_b, T_ref, rot, trans);
        std::printf(
            "pair: %s (%s) kp %d/%d corr %d groups %d collinear %d group %d inliers %d "
            "icp_fitness %.3g icp_inliers %.2f\n",
            to_string(r.status), r.reason.c_str(), r.keypoints_a, r.keypoints_b, r.correspondences,
            r.groups, r.collinear_groups, r.group_size, r.ransac_inliers, r.icp_fitness,
            r.icp_inlier_fraction);
        std::printf("stages: descriptors %.3f s, grouping+RANSAC %.3f s, ICP %.3f s\n",
                    r.descriptor_s, r.grouping_s, r.icp_s);
        std::printf(
            "RESULT matched %d rot_err_deg %.4f trans_err_m %.5f trans_err_pct_extent %.3f "
            "features_s %.3f pair_s %.3f total_s %.3f\n",
            r.matched ? 1 : 0, rot, trans, 100.0 * trans / extent, t_feat, t_pair, t_feat + t_pair);
        if (rep == 0 && fa->status == FeatureStatus::kOk && fb->status == FeatureStatus::kOk) {
            // Diagnosis: how many correspondences agree with the reference?
            const auto corrs =
                match_descriptors(fa->descriptors, fb->descriptors, params.n_C, params.t_C);
            const Eigen::Matrix4f Tf = T_ref.cast<float>();
            const double tol = params.v_K;
            int good = 0;
            for (const auto& c : corrs) {
                const Eigen::Vector3f pbt = (Tf * fb->keypoints.col(c.b).homogeneous()).head<3>();
                good += (pbt - fa->keypoints.col(c.a)).norm() < tol;
            }
            // LRF repeatability on the correct correspondences and where they vote.
            int lrf_ok = 0, n_ok = 0;
            const Eigen::Matrix3f Rref = Tf.topLeftCorner<3, 3>();
            const Eigen::Vector3f true_vote = (Tf * fb->keypoint_centroid.homogeneous()).head<3>();
            double vote_err = 0;
            for (const auto& c : corrs) {
                const Eigen::Vector3f pbt = (Tf * fb->keypoints.col(c.b).homogeneous()).head<3>();
                if ((pbt - fa->keypoints.col(c.a)).norm() >= tol) continue;
                ++n_ok;
                const Eigen::Matrix3f Ra = fa->lrfs[static_cast<std::size_t>(c.a)];
                const Eigen::Matrix3f Rb =
                    fb->lrfs[static_cast<std::size_t>(c.b)] * Rref.transpose();
                const float ang = Eigen::AngleAxisf(Eigen::Matrix3f(Ra * Rb.transpose())).angle();
                lrf_ok += ang < 0.2f;
                const Eigen::Vector3f vote =
                    fa->keypoints.col(c.a) +
                    Ra.transpose() * (fb->lrfs[static_cast<std::size_t>(c.b)] *
                                      (fb->keypoint_centroid - fb->keypoints.col(c.b)));
                vote_err += (vote - true_vote).norm();
            }
            std::printf(
                "diag: correct corr with LRF within 11 deg: %d of %d; mean vote error %.4f m\n",
                lrf_ok, n_ok, n_ok ? vote_err / n_ok : 0.0);
            const auto g = hough_groups(*fa, *fb, corrs, params.v_TF, params.n_TF);
            int gbest = 0;
            if (!g.groups.empty())
                for (int c : g.groups.front()) {
                    const auto& k = corrs[static_cast<std::size_t>(c)];
                    const Eigen::Vector3f pbt =
                        (Tf * fb->keypoints.col(k.b).homogeneous()).head<3>();
                    gbest += (pbt - fa->keypoints.col(k.a)).norm() < tol;
                }
            std::printf(
                "diag: correct corr (within v_K) %d of %zu; largest group %zu with %d correct\n",
                good, corrs.size(), g.groups.empty() ? 0 : g.groups.front().size(), gbest);
            std::cout << "T_est\n" << r.T_a_b << "\nT_ref\n" << T_ref << "\n";
        }
    }
    return 0;
}
