#include "dataset/render.hpp"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "dataset/io.hpp"

namespace maptune::dataset {
namespace fs = std::filesystem;

void Image::set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    const std::size_t k = (std::size_t(y) * width + x) * 3;
    rgb[k] = r;
    rgb[k + 1] = g;
    rgb[k + 2] = b;
}

namespace {

void put_u32(std::string& s, std::uint32_t v) {
    for (int i = 3; i >= 0; --i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

void chunk(std::string& png, const char* type, const std::string& data) {
    put_u32(png, static_cast<std::uint32_t>(data.size()));
    std::string td = std::string(type, 4) + data;
    png += td;
    put_u32(png, static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(td.data()),
                                                  static_cast<uInt>(td.size()))));
}

void line(Image& img, double x0, double y0, double x1, double y1, std::uint8_t r, std::uint8_t g,
          std::uint8_t b, int thick = 1) {
    const int n = static_cast<int>(std::max(std::abs(x1 - x0), std::abs(y1 - y0))) + 1;
    for (int i = 0; i <= n; ++i) {
        const double t = double(i) / n;
        const int x = static_cast<int>(std::lround(x0 + t * (x1 - x0)));
        const int y = static_cast<int>(std::lround(y0 + t * (y1 - y0)));
        for (int dx = -thick / 2; dx <= thick / 2; ++dx)
            for (int dy = -thick / 2; dy <= thick / 2; ++dy) img.set(x + dx, y + dy, r, g, b);
    }
}

// 3x5 digits, enough to label submaps.
void digit_text(Image& img, int x, int y, int value, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
    static const char* glyphs[10] = {"111101101101111", "010110010010111", "111001111100111",
                                     "111001111001111", "101101111001001", "111100111001111",
                                     "111100111101111", "111001001001001", "111101111101111",
                                     "111101111001111"};
    const std::string s = std::to_string(value);
    for (std::size_t c = 0; c < s.size(); ++c) {
        const char* gph = glyphs[s[c] - '0'];
        for (int j = 0; j < 5; ++j)
            for (int i = 0; i < 3; ++i)
                if (gph[j * 3 + i] == '1') {
                    for (int k = 0; k < 4; ++k)
                        img.set(x + static_cast<int>(c) * 8 + i * 2 + k % 2, y + j * 2 + k / 2, r, g, b);
                }
    }
}

// Andrew's monotone chain; closed polygon (first point repeated).
std::vector<Eigen::Vector2d> convex_hull(std::vector<Eigen::Vector2d> p) {
    std::sort(p.begin(), p.end(), [](const auto& a, const auto& b) {
        return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
    });
    if (p.size() < 3) return p;
    auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
        return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
    };
    std::vector<Eigen::Vector2d> h(2 * p.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
        while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
        h[k++] = p[i];
    }
    for (std::size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
        while (k >= t && cross(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
        h[k++] = p[i - 1];
    }
    h.resize(k);
    return h;
}

}  // namespace

void write_png(const fs::path& file, const Image& img) {
    std::string raw;
    raw.reserve(std::size_t(img.height) * (img.width * 3 + 1));
    for (int y = 0; y < img.height; ++y) {
        raw.push_back(0);  // filter: none
        raw.append(reinterpret_cast<const char*>(img.rgb.data()) + std::size_t(y) * img.width * 3,
                   std::size_t(img.width) * 3);
    }
    uLongf len = compressBound(static_cast<uLong>(raw.size()));
    std::string z(len, '\0');
    compress2(reinterpret_cast<Bytef*>(z.data()), &len, reinterpret_cast<const Bytef*>(raw.data()),
              static_cast<uLong>(raw.size()), 9);
    z.resize(len);
    std::string png("\x89PNG\r\n\x1a\n", 8);
    std::string ihdr;
    put_u32(ihdr, static_cast<std::uint32_t>(img.width));
    put_u32(ihdr, static_cast<std::uint32_t>(img.height));
    ihdr += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bit, RGB
    chunk(png, "IHDR", ihdr);
    chunk(png, "IDAT", z);
    chunk(png, "IEND", "");
    write_file(file, png);
}

Image render_run_topdown(const Dataset& ds, int run, int width_px) {
    const RunRecord& r = ds.manifest().runs.at(run);
    struct P {
        Eigen::Vector3d p;
        ColoredPoint c;
    };
    std::vector<P> pts;
    std::vector<std::vector<Eigen::Vector2d>> outlines;
    for (std::size_t i = 0; i < r.submaps.size(); ++i) {
        const Submap s = ds.load_submap(run, static_cast<int>(i));
        std::vector<Eigen::Vector2d> flat;
        for (const auto& q : s.cloud) {
            const Eigen::Vector3d p = s.T_world_submap_gt * Eigen::Vector3d(q.x, q.y, q.z);
            pts.push_back({p, q});
            flat.push_back(p.head<2>());
        }
        const std::vector<Eigen::Vector2d> o = convex_hull(flat);
        outlines.push_back(o);
    }
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
    for (const auto& q : pts) {
        x0 = std::min(x0, q.p.x()); x1 = std::max(x1, q.p.x());
        y0 = std::min(y0, q.p.y()); y1 = std::max(y1, q.p.y());
    }
    const double span = std::max(x1 - x0, y1 - y0) * 1.04 + 1e-9;
    const double s = width_px / span;
    const int h_px = static_cast<int>(std::ceil((y1 - y0) * 1.04 * s)) + 1;
    Image img(width_px, std::max(h_px, 16), 255);
    auto X = [&](double x) { return (x - x0 + 0.02 * span) * s; };
    auto Y = [&](double y) { return h_px - 1 - (y - y0 + 0.02 * span) * s; };
    std::sort(pts.begin(), pts.end(), [](const P& a, const P& b) { return a.p.z() < b.p.z(); });
    for (const auto& q : pts) {  // higher points drawn last: a top-down view
        const int cx = static_cast<int>(X(q.p.x())), cy = static_cast<int>(Y(q.p.y()));
        for (int dx = 0; dx < 2; ++dx)
            for (int dy = 0; dy < 2; ++dy) img.set(cx + dx, cy + dy, q.c.r, q.c.g, q.c.b);
    }
    for (const auto& o : outlines)
        for (std::size_t k = 0; k + 1 < o.size(); ++k)
            line(img, X(o[k].x()), Y(o[k].y()), X(o[k + 1].x()), Y(o[k + 1].y()), 40, 90, 255);
    auto full = [&](const std::string& file, const std::vector<StampedPose>& fallback) {
        return file.empty() ? fallback : read_tum(ds.dir() / file);
    };
    const auto gt = full(r.gt_full_file, r.gt), od = full(r.odometry_full_file, r.odometry);
    for (std::size_t k = 0; k + 1 < od.size(); ++k)
        line(img, X(od[k].T.translation().x()), Y(od[k].T.translation().y()), X(od[k + 1].T.translation().x()),
             Y(od[k + 1].T.translation().y()), 230, 20, 20, 3);
    for (std::size_t k = 0; k + 1 < gt.size(); ++k)
        line(img, X(gt[k].T.translation().x()), Y(gt[k].T.translation().y()), X(gt[k + 1].T.translation().x()),
             Y(gt[k + 1].T.translation().y()), 0, 200, 0, 3);
    for (std::size_t i = 0; i < r.gt.size(); ++i) {
        const Eigen::Vector3d p = r.gt[i].T.translation();
        for (int dx = -3; dx <= 3; ++dx)
            for (int dy = -3; dy <= 3; ++dy) img.set(static_cast<int>(X(p.x())) + dx, static_cast<int>(Y(p.y())) + dy, 0, 0, 0);
        digit_text(img, static_cast<int>(X(p.x())) + 5, static_cast<int>(Y(p.y())) + 5, static_cast<int>(i), 0, 0, 0);
    }
    return img;
}

Image render_submap(const Submap& submap, int w, int h) {
    Image img(w, h, 255);
    // Camera behind the submap's bounding box centre, above, looking forward and down.
    Eigen::Vector3d lo(1e9, 1e9, 1e9), hi(-1e9, -1e9, -1e9);
    for (const auto& q : submap.cloud) {
        const Eigen::Vector3d p(q.x, q.y, q.z);
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
    const Eigen::Vector3d centre = 0.5 * (lo + hi);
    const double radius = 0.5 * (hi - lo).norm();
    const Eigen::Vector3d eye = centre + Eigen::Vector3d(-1.2, -1.2, 1.3).normalized() * radius * 1.9;
    const Eigen::Vector3d fwd = (centre - eye).normalized();
    const Eigen::Vector3d right = fwd.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d up = right.cross(fwd);
    const double f = 0.9 * w;
    std::vector<float> zbuf(std::size_t(w) * h, std::numeric_limits<float>::max());
    auto splat = [&](const Eigen::Vector3d& p, std::uint8_t r, std::uint8_t g, std::uint8_t b, int size, double bias) {
        const Eigen::Vector3d d = p - eye;
        const double z = d.dot(fwd);
        if (z < 0.05) return;
        const int cx = static_cast<int>(w / 2 + f * d.dot(right) / z), cy = static_cast<int>(h / 2 - f * d.dot(up) / z);
        for (int dx = 0; dx < size; ++dx)
            for (int dy = 0; dy < size; ++dy) {
                const int x = cx + dx - size / 2, y = cy + dy - size / 2;
                if (x < 0 || y < 0 || x >= w || y >= h) continue;
                float& zb = zbuf[std::size_t(y) * w + x];
                if (z - bias < zb) {
                    zb = static_cast<float>(z - bias);
                    img.set(x, y, r, g, b);
                }
            }
    };
    const int ps = std::max(2, w / 300);
    for (const auto& q : submap.cloud) splat({q.x, q.y, q.z}, q.r, q.g, q.b, ps, 0);
    for (const auto& o : submap.obstacles) splat(o.cast<double>(), 255, 0, 0, ps + 2, 0.05 * radius);
    return img;
}

}  // namespace maptune::dataset
