#pragma once
// A small synthetic coloured scene (ground plus rocks) for hermetic pipeline tests.

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "dataset/submap.hpp"

namespace maptune::matcher::test {

struct Rock {
    Eigen::Vector3f center;
    Eigen::Vector3f radii;
    std::uint8_t r, g, b;
};

inline std::vector<Rock> make_rocks(unsigned seed, int count, float extent, float extent_y) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    std::vector<Rock> rocks;
    for (int i = 0; i < count; ++i) {
        Rock k;
        k.radii =
            Eigen::Vector3f(0.15f + 0.35f * u(rng), 0.15f + 0.35f * u(rng), 0.1f + 0.3f * u(rng));
        k.center = Eigen::Vector3f(extent * u(rng), extent_y * u(rng), 0.f);
        k.r = static_cast<std::uint8_t>(60 + 190 * u(rng));
        k.g = static_cast<std::uint8_t>(60 + 190 * u(rng));
        k.b = static_cast<std::uint8_t>(60 + 190 * u(rng));
        rocks.push_back(k);
    }
    return rocks;
}

// Scene points (world frame) inside [x0, x1] x [0, extent]: ground at z = 0 with a colour
// texture, ellipsoid caps as rocks (their points are also the obstacles).
inline dataset::Submap make_scene_submap(const std::string& id, float x0, float x1, float extent,
                                         const Eigen::Isometry3f& T_world_submap,
                                         unsigned seed = 11, float spacing = 0.05f,
                                         float extent_y = 0.f) {
    // Rock density of the original 6 x 6 m scene (14 rocks) whatever the extent.
    if (!(extent_y > 0.f)) extent_y = extent;
    const int count = std::max(14, static_cast<int>(14.f * extent * extent_y / 36.f));
    const auto rocks = make_rocks(seed, count, extent, extent_y);
    std::mt19937 rng(seed + 1000);
    std::normal_distribution<float> noise(0.f, 0.003f);
    const Eigen::Isometry3f T_submap_world = T_world_submap.inverse();
    dataset::Submap s;
    s.id = id;
    s.T_world_submap_gt = T_world_submap.cast<double>();
    s.T_world_submap_odom = s.T_world_submap_gt;
    auto add = [&](const Eigen::Vector3f& pw, std::uint8_t r, std::uint8_t g, std::uint8_t b,
                   bool obstacle) {
        if (pw.x() < x0 || pw.x() > x1) return;
        const Eigen::Vector3f p =
            T_submap_world * (pw + Eigen::Vector3f(noise(rng), noise(rng), noise(rng)));
        s.cloud.push_back({p.x(), p.y(), p.z(), r, g, b});
        if (obstacle) s.obstacles.push_back(p);
    };
    for (float x = 0; x <= extent; x += spacing)
        for (float y = 0; y <= extent_y; y += spacing) {
            bool under_rock = false;
            for (const auto& k : rocks) {
                const float dx = (x - k.center.x()) / k.radii.x(),
                            dy = (y - k.center.y()) / k.radii.y();
                if (dx * dx + dy * dy < 1.f) {
                    const float z = k.radii.z() * std::sqrt(1.f - dx * dx - dy * dy);
                    add({x, y, z}, k.r, k.g, k.b, z > 0.03f);
                    under_rock = true;
                    break;
                }
            }
            if (!under_rock) {
                const auto c =
                    static_cast<std::uint8_t>(100 + 40 * std::sin(3.f * x) * std::cos(2.f * y));
                add({x, y, 0.f}, c, c, static_cast<std::uint8_t>(c - 20), false);
            }
        }
    return s;
}

}  // namespace maptune::matcher::test
