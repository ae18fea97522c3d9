// PCL translation unit 1 of 2: per-submap features (SPEC §3 steps 1-6).
#include "matcher/features.hpp"

#include <octomap/OcTree.h>
#include <pcl/console/print.h>
#include <pcl/features/board.h>
#include <pcl/features/normal_3d.h>
#include <pcl/features/shot.h>
#include <pcl/features/shot_lrf.h>
#include <pcl/filters/statistical_outlier_removal.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <unordered_map>
#include <unordered_set>

#include "matcher/direct_kdtree.hpp"
#include "matcher/features_internal.hpp"

namespace maptune::matcher {
namespace {

using PointT = pcl::PointXYZRGBA;
using Cloud = pcl::PointCloud<PointT>;

// Every PCL estimator here searches through DirectKdTree (direct_kdtree.hpp: no OpenMP region
// per query), unsorted like the tree the estimators make by default: the same results.
pcl::search::Search<PointT>::Ptr direct_tree() { return std::make_shared<DirectKdTree<PointT>>(false); }

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

struct VoxelKey {
    std::int64_t x, y, z;
    bool operator==(const VoxelKey& o) const { return x == o.x && y == o.y && z == o.z; }
    bool operator<(const VoxelKey& o) const {
        return x != o.x ? x < o.x : (y != o.y ? y < o.y : z < o.z);
    }
};
struct VoxelKeyHash {
    std::size_t operator()(const VoxelKey& k) const {
        return static_cast<std::size_t>(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
    }
};

// Voxel grid with centroids (and mean colour), in key order so the result is deterministic.
// Own implementation: pcl::VoxelGrid silently returns the input when the grid overflows int32.
Cloud::Ptr voxelize(const Cloud& in, double leaf) {
    auto out = Cloud::Ptr(new Cloud);
    if (!(leaf > 0.0)) {
        *out = in;
        return out;
    }
    struct Acc {
        double x = 0, y = 0, z = 0, r = 0, g = 0, b = 0;
        int n = 0;
    };
    std::unordered_map<VoxelKey, Acc, VoxelKeyHash> voxels;
    voxels.reserve(in.size());
    const double inv = 1.0 / leaf;
    for (const auto& p : in.points) {
        VoxelKey k{static_cast<std::int64_t>(std::floor(p.x * inv)),
                   static_cast<std::int64_t>(std::floor(p.y * inv)),
                   static_cast<std::int64_t>(std::floor(p.z * inv))};
        Acc& a = voxels[k];
        a.x += p.x, a.y += p.y, a.z += p.z, a.r += p.r, a.g += p.g, a.b += p.b, ++a.n;
    }
    std::vector<std::pair<VoxelKey, Acc>> sorted(voxels.begin(), voxels.end());
    std::sort(sorted.begin(), sorted.end(),
              [](const auto& l, const auto& r) { return l.first < r.first; });
    out->reserve(sorted.size());
    for (const auto& [key, a] : sorted) {
        PointT p;
        p.x = static_cast<float>(a.x / a.n);
        p.y = static_cast<float>(a.y / a.n);
        p.z = static_cast<float>(a.z / a.n);
        p.r = static_cast<std::uint8_t>(std::lround(a.r / a.n));
        p.g = static_cast<std::uint8_t>(std::lround(a.g / a.n));
        p.b = static_cast<std::uint8_t>(std::lround(a.b / a.n));
        p.a = 255;
        out->push_back(p);
    }
    return out;
}

// Fraction of sampled voxels within `radius` of `center` that the octree does not know.
double unknown_fraction(const octomap::OcTree& tree, const Eigen::Vector3f& center,
                        const std::vector<Eigen::Vector3f>& offsets) {
    int unknown = 0;
    for (const auto& o : offsets) {
        const Eigen::Vector3f q = center + o;
        octomap::OcTreeKey key;
        if (!tree.coordToKeyChecked(octomap::point3d(q.x(), q.y(), q.z()), key) ||
            tree.search(key) == nullptr) {
            ++unknown;
        }
    }
    return offsets.empty() ? 0.0 : static_cast<double>(unknown) / offsets.size();
}

std::vector<Eigen::Vector3f> ball_offsets(double radius, double step) {
    std::vector<Eigen::Vector3f> offsets;
    const int n = static_cast<int>(std::floor(radius / step));
    for (int i = -n; i <= n; ++i)
        for (int j = -n; j <= n; ++j)
            for (int k = -n; k <= n; ++k) {
                Eigen::Vector3f o(i * step, j * step, k * step);
                if (o.norm() <= radius) offsets.push_back(o);
            }
    return offsets;
}

std::shared_ptr<SubmapFeatures> fail(std::shared_ptr<SubmapFeatures> f, FeatureStatus status,
                                     std::string reason, std::chrono::steady_clock::time_point t0) {
    f->status = status;
    f->reason = std::move(reason);
    f->keypoints.resize(3, 0);
    f->descriptors.resize(0, kDescriptorSize);
    f->lrfs.clear();
    f->duration_s = seconds_since(t0);
    return f;
}

}  // namespace

Deadline Deadline::in(double seconds) {
    Deadline d;
    if (seconds > 0 && seconds < 1e9) {
        d.at = std::chrono::steady_clock::now() +
               std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                   std::chrono::duration<double>(seconds));
    }
    return d;
}

void silence_pcl_console() {
    static std::once_flag once;
    std::call_once(once, [] { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); });
}

std::size_t SubmapFeatures::bytes() const {
    std::size_t b = sizeof(SubmapFeatures) + submap_id.size() + reason.size();
    b += static_cast<std::size_t>(keypoints.size()) * sizeof(float);
    b += static_cast<std::size_t>(descriptors.size()) * sizeof(float);
    b += lrfs.size() * sizeof(Eigen::Matrix3f);
    if (icp_cloud && icp_cloud->cloud) {
        // Points plus roughly the same again for the FLANN index.
        b += icp_cloud->cloud->size() * (sizeof(IcpPoint) + 32);
        if (icp_cloud->source != icp_cloud->cloud) b += icp_cloud->source->size() * sizeof(IcpPoint);
    }
    if (octree) b += octree->memoryUsage();
    return b;
}

namespace {

// Counts `pts` (in the cloud's frame) placed by T into `tree`'s frame: known cells, and free
// cells without an occupied cell within margin (a cube of cells; the nearest surface's).
void count_free(const octomap::OcTree& tree, const pcl::PointCloud<IcpPoint>& pts, const Eigen::Matrix4f& T,
                double margin_m, int max_points, int& known, int& free) {
    if (pts.empty()) return;
    const int reach = static_cast<int>(std::ceil(margin_m / tree.getResolution() - 1e-9));
    const std::size_t stride = std::max<std::size_t>(1, pts.size() / std::max(1, max_points));
    const Eigen::Matrix3f R = T.topLeftCorner<3, 3>();
    const Eigen::Vector3f t = T.topRightCorner<3, 1>();
    for (std::size_t i = 0; i < pts.size(); i += stride) {
        const Eigen::Vector3f q = R * pts[i].getVector3fMap() + t;
        octomap::OcTreeKey key;
        if (!tree.coordToKeyChecked(octomap::point3d(q.x(), q.y(), q.z()), key)) continue;
        const octomap::OcTreeNode* node = tree.search(key);
        if (node == nullptr) continue;  // unknown: neither side of the argument
        ++known;
        if (tree.isNodeOccupied(node)) continue;
        bool near_surface = false;
        for (int dx = -reach; dx <= reach && !near_surface; ++dx)
            for (int dy = -reach; dy <= reach && !near_surface; ++dy)
                for (int dz = -reach; dz <= reach && !near_surface; ++dz) {
                    const int kx = key[0] + dx, ky = key[1] + dy, kz = key[2] + dz;
                    if (kx < 0 || ky < 0 || kz < 0 || kx > 0xFFFF || ky > 0xFFFF || kz > 0xFFFF) continue;
                    const auto* n = tree.search(octomap::OcTreeKey(static_cast<octomap::key_type>(kx),
                                                                   static_cast<octomap::key_type>(ky),
                                                                   static_cast<octomap::key_type>(kz)));
                    near_surface = n != nullptr && tree.isNodeOccupied(n);
                }
        if (!near_surface) ++free;
    }
}

}  // namespace

double FreeSpaceCounts::worst_fraction(int min_known) const {
    double worst = 0.0;
    if (known >= min_known && known > 0) worst = static_cast<double>(free) / known;
    if (reverse_known >= min_known && reverse_known > 0)
        worst = std::max(worst, static_cast<double>(reverse_free) / reverse_known);
    return worst;
}

FreeSpaceCounts free_space_counts(const SubmapFeatures& a, const SubmapFeatures& b,
                                  const Eigen::Matrix4f& T_a_b, double margin_m, int max_points) {
    FreeSpaceCounts c;
    if (a.octree && b.icp_cloud && b.icp_cloud->source)
        count_free(*a.octree, *b.icp_cloud->source, T_a_b, margin_m, max_points, c.known, c.free);
    if (b.octree && a.icp_cloud && a.icp_cloud->source) {
        const Eigen::Matrix4f T_b_a = T_a_b.inverse();
        count_free(*b.octree, *a.icp_cloud->source, T_b_a, margin_m, max_points, c.reverse_known,
                   c.reverse_free);
    }
    return c;
}

std::size_t icp_cloud_size(const SubmapFeatures& f) {
    return f.icp_cloud && f.icp_cloud->cloud ? f.icp_cloud->cloud->size() : 0;
}

std::shared_ptr<const SubmapFeatures> compute_features(const dataset::Submap& submap,
                                                       const MatcherParams& params,
                                                       const MatcherSettings& settings,
                                                       const Deadline& deadline) {
    silence_pcl_console();
    const auto t0 = std::chrono::steady_clock::now();
    auto f = std::make_shared<SubmapFeatures>();
    f->submap_id = submap.id;
    const auto timed_out = [&] { return deadline.expired(); };

    // Input, without non-finite points.
    auto raw = Cloud::Ptr(new Cloud);
    raw->reserve(submap.cloud.size());
    for (const auto& p : submap.cloud) {
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
        PointT q;
        q.x = p.x, q.y = p.y, q.z = p.z, q.r = p.r, q.g = p.g, q.b = p.b, q.a = 255;
        raw->push_back(q);
    }
    f->points_in = static_cast<int>(raw->size());
    if (f->points_in < std::max(settings.min_points, 1))
        return fail(f, FeatureStatus::kFailed, "too few points: " + std::to_string(f->points_in),
                    t0);
    if (!(params.r_N > 0 && params.v_K > 0 && params.r_D > 0 && params.r_LRF > 0))
        return fail(f, FeatureStatus::kFailed, "non-positive radius or leaf size", t0);

    // 1. Statistical outlier removal.
    Cloud::Ptr filtered = raw;
    if (settings.outlier_removal && static_cast<int>(raw->size()) > settings.outlier_mean_k) {
        filtered = Cloud::Ptr(new Cloud);
        pcl::StatisticalOutlierRemoval<PointT> sor;
        sor.setInputCloud(raw);
        sor.setMeanK(settings.outlier_mean_k);
        sor.setStddevMulThresh(settings.outlier_stddev_mul);
        sor.filter(*filtered);
    }
    f->points_filtered = static_cast<int>(filtered->size());
    if (f->points_filtered < std::max(settings.min_points, 1))
        return fail(f, FeatureStatus::kFailed,
                    "too few points after outlier removal: " + std::to_string(f->points_filtered),
                    t0);
    if (timed_out()) return fail(f, FeatureStatus::kTimeout, "timeout after outlier removal", t0);

    // 3. Keypoints: obstacle points (or the cloud as fallback) thinned by v_K, snapped to the
    // nearest filtered cloud point.
    auto candidates = Cloud::Ptr(new Cloud);
    for (const auto& o : submap.obstacles) {
        if (!o.allFinite()) continue;
        PointT q;
        q.x = o.x(), q.y = o.y(), q.z = o.z();
        candidates->push_back(q);
    }
    if (candidates->empty()) {
        f->used_cloud_fallback = true;
        *candidates = *filtered;
    }
    f->keypoint_candidates = static_cast<int>(candidates->size());
    const auto thinned = voxelize(*candidates, params.v_K);
    DirectKdTree<PointT> cloud_tree;
    cloud_tree.setInputCloud(filtered);
    std::vector<int> keypoint_idx;
    keypoint_idx.reserve(thinned->size());
    {
        pcl::Indices nn(1);
        std::vector<float> d2(1);
        for (const auto& p : thinned->points) {
            if (cloud_tree.nearestKSearch(p, 1, nn, d2) == 1) keypoint_idx.push_back(nn[0]);
        }
    }
    std::sort(keypoint_idx.begin(), keypoint_idx.end());
    keypoint_idx.erase(std::unique(keypoint_idx.begin(), keypoint_idx.end()), keypoint_idx.end());
    f->keypoints_voxel = static_cast<int>(keypoint_idx.size());

    // 4. Unknown-space filter: keep iff unknown fraction u <= t_K (t_K >= 1 keeps all).
    if (submap.octree && params.t_K < 1.0) {
        const octomap::OcTree& tree = *submap.octree;
        const double step =
            std::max(tree.getResolution(),
                     2.0 * params.r_D / std::max(1.0, settings.unknown_samples_per_diameter));
        const auto offsets = ball_offsets(params.r_D, step);
        std::vector<int> kept;
        for (int idx : keypoint_idx) {
            const auto& p = (*filtered)[idx];
            if (unknown_fraction(tree, Eigen::Vector3f(p.x, p.y, p.z), offsets) <=
                params.t_K + 1e-9)
                kept.push_back(idx);
        }
        keypoint_idx.swap(kept);
    }
    f->keypoints_unknown = static_cast<int>(keypoint_idx.size());
    if (f->keypoints_unknown < std::max(settings.min_keypoints, 1))
        return fail(f, FeatureStatus::kFailed,
                    "too few keypoints: " + std::to_string(f->keypoints_unknown) + " of " +
                        std::to_string(f->keypoints_voxel) + " after the unknown-space filter",
                    t0);
    if (timed_out()) return fail(f, FeatureStatus::kTimeout, "timeout after keypoints", t0);

    auto keypoints = Cloud::Ptr(new Cloud);
    keypoints->reserve(keypoint_idx.size());
    for (int idx : keypoint_idx) keypoints->push_back((*filtered)[idx]);

    // 2. Normals (radius r_N) at the points of the descriptor surface, from a bounded surface.
    const double k = std::max(1.0, settings.surface_points_per_radius);
    const auto normal_surface = voxelize(*filtered, params.r_N / k);
    auto desc_surface = voxelize(*filtered, params.r_D / k);
    {
        // CSHOT reads only surface points within r_D of a keypoint: estimate normals for
        // those alone (normals were ~40 % of this function on lab submaps; the union of the
        // balls is a fraction of the cloud). The descriptors do not change.
        DirectKdTree<PointT> surface_tree;
        surface_tree.setInputCloud(desc_surface);
        std::vector<char> used(desc_surface->size(), 0);
        pcl::Indices nn;
        std::vector<float> d2;
        for (const auto& p : keypoints->points) {
            surface_tree.radiusSearch(p, params.r_D, nn, d2);
            for (const auto i : nn) used[static_cast<std::size_t>(i)] = 1;
        }
        auto s = Cloud::Ptr(new Cloud);
        for (std::size_t i = 0; i < used.size(); ++i)
            if (used[i]) s->push_back((*desc_surface)[i]);
        desc_surface = s;
    }
    auto normals = pcl::PointCloud<pcl::Normal>::Ptr(new pcl::PointCloud<pcl::Normal>);
    {
        pcl::NormalEstimation<PointT, pcl::Normal> ne;
        ne.setSearchMethod(direct_tree());
        ne.setInputCloud(desc_surface);
        ne.setSearchSurface(normal_surface);
        ne.setRadiusSearch(params.r_N);
        ne.setViewPoint(static_cast<float>(settings.viewpoint_x),
                        static_cast<float>(settings.viewpoint_y),
                        static_cast<float>(settings.viewpoint_z));
        ne.compute(*normals);
    }
    {
        // Surface points without a normal (fewer than 3 neighbours) would poison CSHOT.
        auto s = Cloud::Ptr(new Cloud);
        auto n = pcl::PointCloud<pcl::Normal>::Ptr(new pcl::PointCloud<pcl::Normal>);
        for (std::size_t i = 0; i < desc_surface->size(); ++i) {
            const auto& nn = (*normals)[i];
            if (std::isfinite(nn.normal_x) && std::isfinite(nn.normal_y) &&
                std::isfinite(nn.normal_z)) {
                s->push_back((*desc_surface)[i]);
                n->push_back(nn);
            } else {
                ++f->invalid_normals;
            }
        }
        desc_surface = s;
        normals = n;
    }
    if (desc_surface->size() < 5)
        return fail(f, FeatureStatus::kFailed, "degenerate surface: too few valid normals", t0);
    if (timed_out()) return fail(f, FeatureStatus::kTimeout, "timeout after normals", t0);

    // 5. CSHOT of radius r_D.
    pcl::PointCloud<pcl::SHOT1344> shot;
    {
        pcl::SHOTColorEstimation<PointT, pcl::Normal, pcl::SHOT1344> est;
        est.setSearchMethod(direct_tree());
        est.setInputCloud(keypoints);
        est.setSearchSurface(desc_surface);
        est.setInputNormals(normals);
        est.setRadiusSearch(params.r_D);
        est.compute(shot);
    }
    if (timed_out()) return fail(f, FeatureStatus::kTimeout, "timeout after descriptors", t0);

    // 6. LRFs of radius r_LRF for Hough voting: BOARD (as in PCL's correspondence grouping)
    // or SHOT's LRF (needs no normals).
    pcl::PointCloud<pcl::ReferenceFrame> frames;
    {
        const auto lrf_surface = voxelize(*filtered, params.r_LRF / k);
        if (settings.lrf_method == LrfMethod::kBoard) {
            // BOARD needs normals of its search surface (PCL indexes them like the surface).
            auto surface_normals =
                pcl::PointCloud<pcl::Normal>::Ptr(new pcl::PointCloud<pcl::Normal>);
            pcl::NormalEstimation<PointT, pcl::Normal> ne;
            ne.setSearchMethod(direct_tree());
            ne.setSearchSurface(normal_surface);
            ne.setRadiusSearch(params.r_N);
            ne.setViewPoint(static_cast<float>(settings.viewpoint_x),
                            static_cast<float>(settings.viewpoint_y),
                            static_cast<float>(settings.viewpoint_z));
            ne.setInputCloud(lrf_surface);
            ne.compute(*surface_normals);
            pcl::BOARDLocalReferenceFrameEstimation<PointT, pcl::Normal, pcl::ReferenceFrame> est;
            est.setSearchMethod(direct_tree());
            est.setInputCloud(keypoints);
            est.setInputNormals(surface_normals);
            est.setSearchSurface(lrf_surface);
            est.setRadiusSearch(params.r_LRF);
            est.setFindHoles(true);
            est.compute(frames);
        } else {
            pcl::SHOTLocalReferenceFrameEstimation<PointT, pcl::ReferenceFrame> est;
            est.setSearchMethod(direct_tree());
            est.setInputCloud(keypoints);
            est.setSearchSurface(lrf_surface);
            est.setRadiusSearch(params.r_LRF);
            est.compute(frames);
        }
    }

    // Keep keypoints with a valid descriptor and LRF; normalize descriptors to unit length.
    std::vector<int> good;
    good.reserve(keypoints->size());
    const std::size_t n_kp = std::min({keypoints->size(), shot.size(), frames.size()});
    for (std::size_t i = 0; i < n_kp; ++i) {
        const auto& d = shot[i].descriptor;
        double sq = 0.0;
        bool finite = true;
        for (int j = 0; j < kDescriptorSize; ++j) {
            if (!std::isfinite(d[j])) {
                finite = false;
                break;
            }
            sq += double(d[j]) * d[j];
        }
        if (!finite || sq <= 0.0) {
            ++f->invalid_descriptors;
            continue;
        }
        const auto& fr = frames[i];
        bool lrf_ok = true;
        for (int j = 0; j < 3; ++j)
            lrf_ok = lrf_ok && std::isfinite(fr.x_axis[j]) && std::isfinite(fr.y_axis[j]) &&
                     std::isfinite(fr.z_axis[j]);
        if (!lrf_ok) {
            ++f->invalid_lrfs;
            continue;
        }
        good.push_back(static_cast<int>(i));
    }
    if (static_cast<int>(good.size()) < std::max(settings.min_keypoints, 1))
        return fail(
            f, FeatureStatus::kFailed,
            "too few keypoints with a valid descriptor and LRF: " + std::to_string(good.size()),
            t0);

    f->keypoints.resize(3, static_cast<Eigen::Index>(good.size()));
    f->descriptors.resize(static_cast<Eigen::Index>(good.size()), kDescriptorSize);
    f->lrfs.resize(good.size());
    for (std::size_t r = 0; r < good.size(); ++r) {
        const int i = good[r];
        const auto& p = (*keypoints)[i];
        f->keypoints.col(static_cast<Eigen::Index>(r)) = Eigen::Vector3f(p.x, p.y, p.z);
        Eigen::Map<const Eigen::RowVectorXf> d(shot[i].descriptor, kDescriptorSize);
        f->descriptors.row(static_cast<Eigen::Index>(r)) = d / d.norm();
        const auto& fr = frames[i];
        Eigen::Matrix3f R;
        R.row(0) = Eigen::Map<const Eigen::RowVector3f>(fr.x_axis);
        R.row(1) = Eigen::Map<const Eigen::RowVector3f>(fr.y_axis);
        R.row(2) = Eigen::Map<const Eigen::RowVector3f>(fr.z_axis);
        f->lrfs[r] = R;
    }
    f->keypoint_centroid = f->keypoints.rowwise().mean();

    // ICP cloud with its k-d tree, built once per submap.
    {
        auto icp = std::make_shared<IcpCloud>();
        icp->cloud.reset(new pcl::PointCloud<IcpPoint>);
        const auto src =
            settings.icp_voxel_m > 0 ? voxelize(*filtered, settings.icp_voxel_m) : filtered;
        pcl::PointCloud<pcl::Normal> icp_normals;
        if (settings.icp_point_to_plane) {
            pcl::NormalEstimation<PointT, pcl::Normal> ne;
            ne.setSearchMethod(direct_tree());
            ne.setInputCloud(src);
            ne.setRadiusSearch(settings.icp_voxel_m > 0 ? 3.0 * settings.icp_voxel_m : params.r_N);
            ne.compute(icp_normals);
        }
        icp->cloud->reserve(src->size());
        for (std::size_t i = 0; i < src->size(); ++i) {
            const auto& p = (*src)[i];
            IcpPoint q;
            q.x = p.x, q.y = p.y, q.z = p.z;
            q.normal_x = q.normal_y = q.normal_z = q.curvature = 0.f;
            if (settings.icp_point_to_plane) {
                const auto& n = icp_normals[i];
                // A point without a normal would make the point-to-plane system singular.
                if (!std::isfinite(n.normal_x) || !std::isfinite(n.normal_y) ||
                    !std::isfinite(n.normal_z))
                    continue;
                q.normal_x = n.normal_x, q.normal_y = n.normal_y, q.normal_z = n.normal_z;
                q.curvature = n.curvature;
            }
            icp->cloud->push_back(q);
        }
        icp->tree.reset(new DirectKdTree<IcpPoint>);
        icp->tree->setInputCloud(icp->cloud);
        // As ICP source, one point per coarser voxel: point-to-plane accuracy comes from the
        // target's normals, and the source size is what every iteration's searches cost.
        icp->source = icp->cloud;
        const double source_leaf = settings.icp_source_voxel_factor * settings.icp_voxel_m;
        if (settings.icp_voxel_m > 0 && settings.icp_source_voxel_factor > 1.0) {
            icp->source.reset(new pcl::PointCloud<IcpPoint>);
            std::unordered_set<VoxelKey, VoxelKeyHash> seen;
            const double inv = 1.0 / source_leaf;
            for (const auto& q : icp->cloud->points) {
                const VoxelKey cell{static_cast<std::int64_t>(std::floor(q.x * inv)),
                                    static_cast<std::int64_t>(std::floor(q.y * inv)),
                                    static_cast<std::int64_t>(std::floor(q.z * inv))};
                if (seen.insert(cell).second) icp->source->push_back(q);
            }
        }
        f->icp_cloud = icp;
    }
    if (settings.max_free_space_fraction > 0) f->octree = submap.octree;

    f->status = FeatureStatus::kOk;
    f->duration_s = seconds_since(t0);
    return f;
}

}  // namespace maptune::matcher
