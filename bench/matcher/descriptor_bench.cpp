// Descriptor matching speed: blocked float GEMM (match_descriptors) vs PCL KdTreeFLANN per
// query vs the exhaustive oracle, on CSHOT descriptors of a real pair.
//
//   matcher_descriptor_bench --target A --source B [--params k=v,...] [--queries N] [--reps N]
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "matcher/cloud_io.hpp"
#include "matcher/descriptor_matching.hpp"
#include "matcher/matcher.hpp"

using namespace maptune::matcher;

namespace {
double now_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}
std::map<std::string, double> parse_kv(const std::string& s) {
    std::map<std::string, double> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        if (auto eq = item.find('='); eq != std::string::npos)
            out[item.substr(0, eq)] = std::atof(item.c_str() + eq + 1);
    return out;
}
pcl::PointCloud<pcl::SHOT1344>::Ptr to_pcl(const DescriptorMatrix& D) {
    pcl::PointCloud<pcl::SHOT1344>::Ptr c(new pcl::PointCloud<pcl::SHOT1344>);
    c->resize(static_cast<std::size_t>(D.rows()));
    for (Eigen::Index i = 0; i < D.rows(); ++i) {
        for (int j = 0; j < kDescriptorSize; ++j)
            (*c)[static_cast<std::size_t>(i)].descriptor[j] = D(i, j);
        for (int j = 0; j < 9; ++j) (*c)[static_cast<std::size_t>(i)].rf[j] = 0.f;
    }
    return c;
}
}  // namespace

int main(int argc, char** argv) {
    std::string target, source, params_s;
    int queries = 300, reps = 3;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string k = argv[i], v = argv[i + 1];
        if (k == "--target")
            target = v;
        else if (k == "--source")
            source = v;
        else if (k == "--params")
            params_s = v;
        else if (k == "--queries")
            queries = std::atoi(v.c_str());
        else if (k == "--reps")
            reps = std::atoi(v.c_str());
    }
    if (target.empty() || source.empty()) {
        std::cerr << "usage: matcher_descriptor_bench --target A --source B [--params k=v,...]\n";
        return 2;
    }
    const auto params = from_named_values(parse_kv(params_s));
    FeatureCacheOptions cache;
    cache.key_quantum = 1e-5;
    Matcher m({}, cache);
    std::vector<Eigen::Vector3f> pa, pb;
    std::string error;
    if (!io::read_scan_pair(target, source, pa, pb, error)) {
        std::cerr << "error: " << error << "\n";
        return 1;
    }
    const auto fa = m.features(io::make_submap("a", pa), params);
    const auto fb = m.features(io::make_submap("b", pb), params);
    if (fa->status != FeatureStatus::kOk || fb->status != FeatureStatus::kOk) {
        std::cerr << "features failed: " << fa->reason << " / " << fb->reason << "\n";
        return 1;
    }
    const auto& A = fa->descriptors;
    const auto& B = fb->descriptors;
    const double na = static_cast<double>(A.rows()), nb = static_cast<double>(B.rows());
    std::printf("descriptors: A %d x %d, B %d x %d, n_C %d, t_C %.2f\n", int(A.rows()),
                int(A.cols()), int(B.rows()), int(B.cols()), params.n_C, params.t_C);

    // 1. GEMM matcher, both directions.
    std::vector<Correspondence> fast;
    double best = 1e9;
    for (int r = 0; r < reps; ++r) {
        const double t0 = now_s();
        fast = match_descriptors(A, B, params.n_C, params.t_C);
        best = std::min(best, now_s() - t0);
    }
    std::printf(
        "GEMM matcher (both directions): %.4f s  = %.2f us per query  (%.1f GFLOP/s of "
        "GEMM work), %zu correspondences\n",
        best, 1e6 * best / (na + nb), 2.0 * na * nb * kDescriptorSize / best / 1e9, fast.size());

    // 2. KdTreeFLANN (exact, single k-d tree as PCL configures it), per query.
    const double tb0 = now_s();
    pcl::KdTreeFLANN<pcl::SHOT1344> tree_b;
    tree_b.setInputCloud(to_pcl(B));
    const double t_build = now_s() - tb0;
    const auto qa = to_pcl(A);
    const int nq = std::min<int>(queries, static_cast<int>(A.rows()));
    pcl::Indices idx(static_cast<std::size_t>(params.n_C));
    std::vector<float> d2(static_cast<std::size_t>(params.n_C));
    int agree = 0;
    const double tq0 = now_s();
    std::vector<std::vector<int>> flann_nn(static_cast<std::size_t>(nq));
    for (int q = 0; q < nq; ++q) {
        tree_b.nearestKSearch((*qa)[static_cast<std::size_t>(q)], params.n_C, idx, d2);
        flann_nn[static_cast<std::size_t>(q)].assign(idx.begin(), idx.end());
    }
    const double per_query = (now_s() - tq0) / nq;
    // Agreement of the nearest neighbour with the GEMM scores (threshold-free check).
    for (int q = 0; q < nq; ++q) {
        Eigen::Index j;
        (B * A.row(q).transpose()).maxCoeff(&j);
        agree += !flann_nn[static_cast<std::size_t>(q)].empty() &&
                 flann_nn[static_cast<std::size_t>(q)][0] == static_cast<int>(j);
    }
    std::printf(
        "KdTreeFLANN: build %.3f s, %.3f ms per query (%d queries); both directions "
        "extrapolated: %.2f s; nearest neighbour agrees with GEMM for %d of %d\n",
        t_build, 1e3 * per_query, nq, per_query * (na + nb) + t_build, agree, nq);
    std::printf("speed-up GEMM vs KdTreeFLANN (both directions): %.0fx\n",
                (per_query * (na + nb) + t_build) / best);

    // 3. Oracle on a subset (exactness check of the thresholded bidirectional result).
    const int ns = std::min<int>(400, static_cast<int>(std::min(A.rows(), B.rows())));
    const DescriptorMatrix As = A.topRows(ns), Bs = B.topRows(ns);
    const double to0 = now_s();
    const auto oracle = match_descriptors_brute_force(As, Bs, params.n_C, params.t_C);
    const double t_oracle = now_s() - to0;
    const auto fast_s = match_descriptors(As, Bs, params.n_C, params.t_C);
    std::size_t same = 0;
    for (std::size_t i = 0; i < std::min(oracle.size(), fast_s.size()); ++i)
        same += oracle[i].a == fast_s[i].a && oracle[i].b == fast_s[i].b;
    std::printf(
        "oracle on %d x %d: %.3f s; GEMM result %zu vs oracle %zu correspondences, %zu "
        "identical in order\n",
        ns, ns, t_oracle, fast_s.size(), oracle.size(), same);
    return 0;
}
