#include "dataset/simulator.hpp"

#include <octomap/OcTree.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <tuple>

#include "dataset/dataset.hpp"
#include "dataset/geometry.hpp"

namespace maptune::dataset {
namespace fs = std::filesystem;

SimConfig sim_preset(const std::string& name) {
    SimConfig c;
    if (name == "lab" || name == "lab-tiny") {
        c.world = "lab";
        c.max_range_m = 4.0;
        c.pan_sweep_deg = {-45, -15, 15, 45, 15, -15};
        if (name == "lab") {
            // A hall of 16 m x 16 m at the 8 m room's mean rock density (22.5 rocks per 64 m²):
            // most submap pairs of a run no longer see the same rocks, so a matcher meets
            // look-alike rock fields as on the LRU's lab runs ("most of the submaps do not
            // overlap", thesis §5.3); docs/datasets.md, "Calibration".
            c.world_size = 16;
            c.rocks = 90;
            c.path_unstick = 1;
        }
        if (name == "lab-tiny") {
            c.runs = 2;
            c.submaps = 4;
            c.image_width = 48;
            c.image_height = 36;
            c.octomap_resolution_m = 0.1;
            c.voxel_m = 0.06;
        }
        return c;
    }
    if (name == "moon" || name == "moon-tiny") {
        c.world = "moon";
        c.runs = 40;
        c.submaps = 40;
        c.world_size = 60;
        c.max_range_m = 8.0;
        c.frame_step_m = 0.25;
        c.submap_distance_m = 2.5;
        c.submap_sigma_m = 0.08;
        c.voxel_m = 0.08;
        c.octomap_resolution_m = 0.1;
        c.octomap_pixel_stride = 2;
        c.tilt_deg = -22;
        c.sigma_x = 0.025;
        c.sigma_y = 0.015;
        c.sigma_yaw = 0.008;
        if (name == "moon") {
            // Calibrated against the thesis's simulated world (docs/datasets.md, "Calibration"):
            // angular rocks keep local frames repeatable between views; submaps at the lab's
            // 1.2 m and a 5 m range halve the lever arm that scattered Hough votes 1.5-3 m on
            // 2.5 m / 8 m submaps; 1200 rocks (~14 % of the ground; small ones driven over, as
            // a rover does) give the obstacle detector keypoints. With 600 (~7 %) pairs more than
            // a few submaps apart matched mostly by chance over 40-submap runs.
            c.rocks = 1200;
            c.rock_facets = 8;
            c.rock_drive_over_m = 0.15;
            c.submap_distance_m = 1.2;
            c.max_range_m = 5.0;
            c.voxel_m = 0.06;
            c.path_unstick = 1;
        }
        if (name == "moon-tiny") {
            c.runs = 2;
            c.submaps = 4;
            c.world_size = 30;
            c.craters = 15;
            c.image_width = 48;
            c.image_height = 36;
            c.octomap_resolution_m = 0.2;
            c.voxel_m = 0.12;
        }
        return c;
    }
    throw std::invalid_argument("unknown preset '" + name + "' (lab, moon, lab-tiny, moon-tiny)");
}

std::vector<std::string> sim_preset_names() { return {"lab", "moon", "lab-tiny", "moon-tiny"}; }

namespace {

struct SimField {
    double* real = nullptr;
    int* integer = nullptr;
    double lo = 0, hi = 0;
};

// The one list of fields `--sim` may set, with their valid ranges.
std::map<std::string, SimField> sim_fields(SimConfig& c) {
    auto r = [](double& f, double lo, double hi) { return SimField{&f, nullptr, lo, hi}; };
    auto i = [](int& f, double lo, double hi) { return SimField{nullptr, &f, lo, hi}; };
    return {
        {"world_size", r(c.world_size, 2, 1000)},
        {"rocks", i(c.rocks, 0, 100000)},
        {"craters", i(c.craters, 0, 100000)},
        {"worlds", i(c.worlds, 1, 1000)},
        {"rock_colour_variation", r(c.rock_colour_variation, 0, 1)},
        {"floor_tile_contrast", r(c.floor_tile_contrast, 0, 1)},
        {"rock_facets", i(c.rock_facets, 0, 64)},
        {"rock_molds", i(c.rock_molds, 0, 100000)},
        {"rock_roughness_m", r(c.rock_roughness_m, 0, 1)},
        {"rock_size_exponent", r(c.rock_size_exponent, 0, 10)},
        {"rock_min_m", r(c.rock_min_m, 0.02, 1.5)},
        {"rock_drive_over_m", r(c.rock_drive_over_m, 0, 10)},
        {"cast_shadows", i(c.cast_shadows, 0, 1)},
        {"image_width", i(c.image_width, 8, 4096)},
        {"image_height", i(c.image_height, 8, 4096)},
        {"hfov_deg", r(c.hfov_deg, 1, 170)},
        {"vfov_deg", r(c.vfov_deg, 1, 170)},
        {"baseline_m", r(c.baseline_m, 0.001, 10)},
        {"focal_px", r(c.focal_px, 1, 1e5)},
        {"disparity_sigma_px", r(c.disparity_sigma_px, 0, 10)},
        {"camera_height_m", r(c.camera_height_m, 0.05, 10)},
        {"tilt_deg", r(c.tilt_deg, -90, 90)},
        {"max_range_m", r(c.max_range_m, 0.2, 1000)},
        {"hole_probability", r(c.hole_probability, 0, 0.99)},
        {"exposure_sigma", r(c.exposure_sigma, 0, 1)},
        {"frame_step_m", r(c.frame_step_m, 0.01, 10)},
        {"path_wander", r(c.path_wander, 0, 10)},
        {"path_unstick", i(c.path_unstick, 0, 1)},
        {"submap_distance_m", r(c.submap_distance_m, 0.05, 1000)},
        {"submap_sigma_m", r(c.submap_sigma_m, 0.001, 100)},
        {"voxel_m", r(c.voxel_m, 0.005, 10)},
        {"octomap_resolution_m", r(c.octomap_resolution_m, 0.005, 10)},
        {"octomap_pixel_stride", i(c.octomap_pixel_stride, 1, 64)},
        {"obstacle_max_height_m", r(c.obstacle_max_height_m, 0, 10)},
        {"obstacle_cell_m", r(c.obstacle_cell_m, 0, 10)},
        {"sigma_x", r(c.sigma_x, 0, 10)},
        {"sigma_y", r(c.sigma_y, 0, 10)},
        {"sigma_yaw", r(c.sigma_yaw, 0, 10)},
        {"sigma_roll_pitch", r(c.sigma_roll_pitch, 0, 10)},
        {"scale_bias_sigma", r(c.scale_bias_sigma, 0, 1)},
    };
}

bool parse_double(const std::string& text, double& out) {
    char* end = nullptr;
    out = std::strtod(text.c_str(), &end);
    return !text.empty() && end != text.c_str() && *end == '\0' && std::isfinite(out);
}

std::string format_number(double v) {
    std::ostringstream os;
    os.precision(12);
    os << v;
    return os.str();
}

}  // namespace

std::string set_sim_option(SimConfig& c, const std::string& key, const std::string& value) {
    if (key == "pan_sweep_deg") {
        std::vector<double> sweep;
        std::stringstream in(value);
        for (std::string item; std::getline(in, item, ',');) {
            double v = 0;
            if (!parse_double(item, v) || v < -180 || v > 180) {
                return "--sim pan_sweep_deg: '" + item + "' is not an angle in [-180, 180] degrees";
            }
            sweep.push_back(v);
        }
        if (sweep.empty()) return "--sim pan_sweep_deg: expected a comma-separated list of angles";
        c.pan_sweep_deg = sweep;
        return "";
    }
    auto fields = sim_fields(c);
    const auto it = fields.find(key);
    if (it == fields.end()) {
        std::string known = "pan_sweep_deg";
        for (const auto& [k, f] : fields) known += ", " + k;
        return "--sim: unknown simulator setting '" + key + "' (known: " + known + ")";
    }
    const SimField& f = it->second;
    double v = 0;
    if (!parse_double(value, v) || v < f.lo || v > f.hi || (f.integer && v != std::floor(v))) {
        return "--sim " + key + ": '" + value + "' is not " + (f.integer ? "an integer" : "a number") + " in [" +
               format_number(f.lo) + ", " + format_number(f.hi) + "]";
    }
    if (f.real) *f.real = v;
    else *f.integer = static_cast<int>(v);
    return "";
}

namespace {

// Every setting as KEY=VALUE; `every` = false leaves out settings added after datasets were
// published while they have their default, so those datasets' meta and ids stay as they were.
std::vector<std::string> sim_options(const SimConfig& config, bool every) {
    SimConfig c = config;
    std::vector<std::string> out;
    for (const auto& [k, f] : sim_fields(c)) {
        if (!every && k == "worlds" && c.worlds == 1) continue;
        out.push_back(k + "=" + format_number(f.real ? *f.real : *f.integer));
    }
    std::string sweep;
    for (double a : c.pan_sweep_deg) sweep += (sweep.empty() ? "" : ",") + format_number(a);
    out.push_back("pan_sweep_deg=" + sweep);
    return out;
}

}  // namespace

std::vector<std::string> sim_options(const SimConfig& config) { return sim_options(config, false); }

std::string sim_settings_mismatch(const SimConfig& config, const std::map<std::string, std::string>& meta) {
    auto split = [](const std::vector<std::string>& options) {
        std::map<std::string, std::string> kv;
        for (const std::string& o : options) {
            const auto eq = o.find('=');
            if (eq != std::string::npos) kv[o.substr(0, eq)] = o.substr(eq + 1);
        }
        return kv;
    };
    std::map<std::string, std::string> wanted = split(sim_options(config, true));
    std::map<std::string, std::string> had = split(sim_options(SimConfig{}, true));
    if (const auto it = meta.find("sim"); it != meta.end()) {
        std::vector<std::string> options;
        std::istringstream in(it->second);
        for (std::string o; in >> o;) options.push_back(o);
        for (auto& [k, v] : split(options)) had[k] = v;
    }
    // Not among the sim options: their own meta keys (generate_dataset).
    for (const auto& [key, value] : std::map<std::string, std::string>{{"world", config.world},
                                                                      {"seed", std::to_string(config.seed)},
                                                                      {"runs", std::to_string(config.runs)},
                                                                      {"submaps", std::to_string(config.submaps)}}) {
        wanted[key] = value;
        const auto it = meta.find(key);
        had[key] = it == meta.end() ? "(none)" : it->second;
    }
    std::string first;
    int differing = 0;
    for (const auto& [k, v] : wanted) {
        const auto it = had.find(k);
        const std::string h = it == had.end() ? "(none)" : it->second;
        if (h == v) continue;
        if (differing++ == 0) first = k + ": the dataset has " + h + ", the settings ask for " + v;
    }
    if (differing > 1) first += " (and " + std::to_string(differing - 1) + " more)";
    return first;
}

namespace {

// ---------------------------------------------------------------- randomness

// SplitMix64 and Box-Muller written out so that output is identical on every platform
// (std::normal_distribution is implementation-defined).
class Rng {
public:
    explicit Rng(std::uint64_t seed) : s_(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (s_ += 0x9e3779b97f4a7c15ull);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
        return z ^ (z >> 31);
    }
    double uniform() { return (next() >> 11) * (1.0 / 9007199254740992.0); }
    double uniform(double a, double b) { return a + (b - a) * uniform(); }
    double normal() {
        const double u1 = std::max(uniform(), 1e-300), u2 = uniform();
        return std::sqrt(-2.0 * std::log(u1)) * std::cos(2 * M_PI * u2);
    }

private:
    std::uint64_t s_;
};

std::uint64_t mix(std::uint64_t a, std::uint64_t b) {
    Rng r(a * 0x9e3779b97f4a7c15ull ^ (b + 0x632be59bd9b4e019ull));
    return r.next();
}

// Hash-based value noise in [0, 1], smooth (cubic fade), in world coordinates, so colour
// belongs to the surface and not to the view.
float hash3(std::int64_t x, std::int64_t y, std::int64_t z, std::uint32_t seed) {
    std::uint64_t h = static_cast<std::uint64_t>(x) * 0x8da6b343ull ^
                      static_cast<std::uint64_t>(y) * 0xd8163841ull ^
                      static_cast<std::uint64_t>(z) * 0xcb1ab31full ^ seed * 0x9e3779b1ull;
    h ^= h >> 29;
    h *= 0xbf58476d1ce4e5b9ull;
    h ^= h >> 32;
    return static_cast<float>(h & 0xffffff) / float(0xffffff);
}

float fade(float t) { return t * t * (3 - 2 * t); }

float value_noise3(float x, float y, float z, std::uint32_t seed) {
    const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
    const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy),
               iz = static_cast<std::int64_t>(fz);
    const float tx = fade(x - fx), ty = fade(y - fy), tz = fade(z - fz);
    float c[2][2][2];
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
            for (int d = 0; d < 2; ++d) c[a][b][d] = hash3(ix + a, iy + b, iz + d, seed);
    auto lerp = [](float u, float v, float t) { return u + (v - u) * t; };
    const float x00 = lerp(c[0][0][0], c[1][0][0], tx), x10 = lerp(c[0][1][0], c[1][1][0], tx);
    const float x01 = lerp(c[0][0][1], c[1][0][1], tx), x11 = lerp(c[0][1][1], c[1][1][1], tx);
    return lerp(lerp(x00, x10, ty), lerp(x01, x11, ty), tz);
}

float fbm2(float x, float y, std::uint32_t seed, int octaves) {
    float sum = 0, amp = 0.5f, norm = 0;
    for (int o = 0; o < octaves; ++o) {
        sum += amp * value_noise3(x, y, 0.37f * o, seed + o);
        norm += amp;
        x *= 2.03f;
        y *= 2.03f;
        amp *= 0.5f;
    }
    return sum / norm;
}

// ---------------------------------------------------------------- worlds

struct Rgb {
    float r, g, b;
};

enum Material : std::uint16_t { kGround = 0, kWall = 1, kRock = 2 /* + rock index */ };

struct Disc {
    double x, y, r;  // keep-out circle for the path planner
};

class World {
public:
    World(const SimConfig& c, std::uint64_t seed)
        : lab_(c.world == "lab"), seed_(seed), rock_var_(static_cast<float>(c.rock_colour_variation)),
          floor_contrast_(static_cast<float>(c.floor_tile_contrast)), facets_(c.rock_facets), molds_(c.rock_molds),
          roughness_(static_cast<float>(c.rock_roughness_m)) {
        if (c.world != "lab" && c.world != "moon") {
            throw std::invalid_argument("unknown world '" + c.world + "' (lab|moon)");
        }
        size_ = c.world_size;
        res_ = lab_ ? 0.02 : 0.05;
        const double margin = lab_ ? 1.0 : 2.0;  // thick walls / terrain beyond the drive area
        x0_ = -margin;
        y0_ = -margin;
        nx_ = static_cast<int>(std::ceil((size_ + 2 * margin) / res_)) + 1;
        ny_ = nx_;
        h_.assign(static_cast<std::size_t>(nx_) * ny_, 0.f);
        mat_.assign(h_.size(), kGround);
        Rng rng(mix(seed, 0x574f524cull));
        if (lab_) build_lab(c, rng);
        else build_moon(c, rng);
        build_block_max();
        if (!lab_ && c.cast_shadows != 0) build_shadows();
    }

    bool lab() const { return lab_; }
    double size() const { return size_; }
    const std::vector<Disc>& keep_out() const { return keep_out_; }

    float cell_h(int i, int j) const {
        i = std::clamp(i, 0, nx_ - 1);
        j = std::clamp(j, 0, ny_ - 1);
        return h_[static_cast<std::size_t>(j) * nx_ + i];
    }
    float height(double x, double y) const {
        const double gx = (x - x0_) / res_, gy = (y - y0_) / res_;
        const int i = static_cast<int>(std::floor(gx)), j = static_cast<int>(std::floor(gy));
        const float tx = static_cast<float>(gx - i), ty = static_cast<float>(gy - j);
        const float a = cell_h(i, j), b = cell_h(i + 1, j), c = cell_h(i, j + 1), d = cell_h(i + 1, j + 1);
        return (a * (1 - tx) + b * tx) * (1 - ty) + (c * (1 - tx) + d * tx) * ty;
    }
    bool inside(double x, double y) const {
        return x > x0_ && y > y0_ && x < x0_ + (nx_ - 1) * res_ && y < y0_ + (ny_ - 1) * res_;
    }
    std::uint16_t material(double x, double y) const {
        const int i = std::clamp(static_cast<int>(std::lround((x - x0_) / res_)), 0, nx_ - 1);
        const int j = std::clamp(static_cast<int>(std::lround((y - y0_) / res_)), 0, ny_ - 1);
        return mat_[static_cast<std::size_t>(j) * nx_ + i];
    }
    Eigen::Vector3d normal(double x, double y) const {
        const double e = res_;
        const double dx = (height(x + e, y) - height(x - e, y)) / (2 * e);
        const double dy = (height(x, y + e) - height(x, y - e)) / (2 * e);
        return Eigen::Vector3d(-dx, -dy, 1).normalized();
    }

    // Ray march against the height field; returns the distance to the first hit.
    bool raycast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_t, double& t_hit) const {
        const double min_step = 0.01, max_step = lab_ ? 0.06 : 0.12;
        const double dxy = std::max(1e-9, std::hypot(d.x(), d.y()));
        double t = 0.05, t_prev = t;
        while (t < max_t) {
            const Eigen::Vector3d p = o + t * d;
            if (!inside(p.x(), p.y())) return false;
            // Above every surface within one block: a long step that provably stays above.
            const double hmax = block_max(p.x(), p.y());
            if (p.z() > hmax + 1e-3) {
                double dt = block_ / dxy;
                if (d.z() < 0) dt = std::min(dt, (p.z() - hmax) / -d.z());
                if (dt > min_step) {
                    t_prev = t;
                    t += dt;
                    continue;
                }
            }
            const double dz = p.z() - height(p.x(), p.y());
            if (dz < 0) {
                double lo = t_prev, hi = t;
                for (int k = 0; k < 8; ++k) {
                    const double mid = 0.5 * (lo + hi);
                    const Eigen::Vector3d q = o + mid * d;
                    (q.z() - height(q.x(), q.y()) < 0 ? hi : lo) = mid;
                }
                t_hit = 0.5 * (lo + hi);
                return true;
            }
            t_prev = t;
            t += std::clamp(0.5 * dz, min_step, max_step);
        }
        return false;
    }

    // Lambertian shading of a procedural albedo: view-independent, tied to the surface.
    Rgb colour(const Eigen::Vector3d& p) const {
        const std::uint16_t m = material(p.x(), p.y());
        const float x = static_cast<float>(p.x()), y = static_cast<float>(p.y()), z = static_cast<float>(p.z());
        const auto s = static_cast<std::uint32_t>(seed_);
        Rgb a;
        if (lab_) {
            if (m == kWall && z > 0.05f) {
                // Painted wall with posters: patches of colour in (along-wall, height).
                const float u = x + y;
                const float patch = value_noise3(u * 1.3f, z * 1.3f, 0, s + 11);
                const float hue = value_noise3(std::floor(u * 1.3f), std::floor(z * 1.3f), 5, s + 12);
                if (patch > 0.62f && z > 0.5f && z < 2.0f) {
                    a = {0.3f + 0.6f * hue, 0.8f - 0.5f * hue, 0.3f + 0.4f * (1 - hue)};
                } else {
                    const float n = 0.85f + 0.1f * value_noise3(u * 8, z * 8, 0, s + 13);
                    a = {n, n * 0.97f, n * 0.92f};
                }
            } else if (m >= kRock) {
                const float h = hash3(m, 0, 0, s + 21);
                const float tint = rock_var_ == 1.f ? h : 0.5f + rock_var_ * (h - 0.5f);  // 1: bit-exact as before
                const float n = 0.6f + 0.4f * fbm2(x * 9 + z * 3, y * 9 - z * 3, s + 22 + m, 3);
                a = {n * (0.55f + 0.25f * tint), n * (0.42f + 0.1f * tint), n * (0.32f - 0.1f * tint)};
            } else {
                // Floor: carpet tiles 0.5 m with seams and fine speckle.
                const float fx = x * 2 - std::floor(x * 2), fy = y * 2 - std::floor(y * 2);
                const bool seam = fx < 0.04f || fy < 0.04f;
                const float tile = hash3(static_cast<std::int64_t>(std::floor(x * 2)),
                                         static_cast<std::int64_t>(std::floor(y * 2)), 1, s + 31);
                const float n = 0.7f + 0.3f * value_noise3(x * 20, y * 20, 0, s + 32);
                const float tiled = 0.45f + 0.15f * tile;
                const float base = (1 - floor_contrast_) * 0.525f +
                                   floor_contrast_ * (seam ? 0.25f : tiled);
                a = {base * n * 0.9f, base * n * 0.95f, base * n * 1.1f};
            }
        } else {
            const float n = 0.55f + 0.45f * fbm2(x * 0.8f, y * 0.8f, s + 41, 4);
            const float fine = 0.8f + 0.2f * value_noise3(x * 12, y * 12, z * 12, s + 42);
            float g = n * fine;
            if (m >= kRock) g *= 0.6f + 0.5f * hash3(m, 1, 0, s + 43);
            a = {g * 0.62f, g * 0.6f, g * 0.57f};
        }
        const Eigen::Vector3d nrm = normal(p.x(), p.y());
        // Lab: diffuse ceiling light; moon: low sun, hard shading (features stand out).
        const Eigen::Vector3d sun = lab_ ? Eigen::Vector3d(0.2, 0.1, 1).normalized() : moon_sun();
        double lambert = std::max(0.0, nrm.dot(sun));
        if (!shadow_.empty() && in_shadow(p.x(), p.y())) lambert = 0;
        if (m == kWall && lab_ && p.z() > 0.05) lambert = 0.8;  // height field walls have no true normal
        const float shade = static_cast<float>(lab_ ? 0.45 + 0.55 * lambert : 0.15 + 0.95 * lambert);
        return {a.r * shade, a.g * shade, a.b * shade};
    }

    // Textureless patches fail stereo matching: a fixed fraction of the surface.
    bool stereo_hole(const Eigen::Vector3d& p) const {
        return value_noise3(static_cast<float>(p.x() * 2.2), static_cast<float>(p.y() * 2.2),
                            static_cast<float>(p.z() * 2.2), static_cast<std::uint32_t>(seed_) + 77) < 0.07f;
    }

    HeightMapImage height_map(double resolution) const {
        HeightMapImage img;
        img.resolution = resolution;
        img.x0 = 0;
        img.y0 = 0;
        img.nx = static_cast<int>(size_ / resolution);
        img.ny = img.nx;
        for (int j = 0; j < img.ny; ++j)
            for (int i = 0; i < img.nx; ++i)
                img.height.push_back(height((i + 0.5) * resolution, (j + 0.5) * resolution));
        return img;
    }

private:
    void stamp(double cx, double cy, double rx, double ry, double rot, double height_m,
               std::uint16_t mat, std::uint32_t bump_seed, bool additive) {
        // Faceted rocks: a convex polyhedron of planes tangent to the half-ellipsoid (rx, ry,
        // height) — side facets all around, shoulder facets above them and a tilted top —
        // so that a rock has flat faces and sharp edges as broken and cast rocks do. Their
        // directions come from the rock's own stream, so the rest of the world is unchanged.
        struct Plane {
            double nx, ny, nz, s;
        };
        std::vector<Plane> planes;
        if (facets_ > 0) {
            Rng frng(mix(seed_, 0x46414345ull + bump_seed));
            const double az0 = frng.uniform(0, 2 * M_PI);
            auto add = [&](double az, double el) {
                const double nx = std::cos(el) * std::cos(az), ny = std::cos(el) * std::sin(az), nz = std::sin(el);
                planes.push_back({nx, ny, nz, std::sqrt(rx * rx * nx * nx + ry * ry * ny * ny + height_m * height_m * nz * nz)});
            };
            for (int k = 0; k < facets_; ++k) {
                add(az0 + 2 * M_PI * (k + frng.uniform(-0.3, 0.3)) / facets_, frng.uniform(0.25, 0.6));
            }
            const int shoulders = facets_ / 2 + 1;
            for (int k = 0; k < shoulders; ++k) {
                add(az0 + 2 * M_PI * (k + 0.5 + frng.uniform(-0.3, 0.3)) / shoulders, frng.uniform(0.8, 1.2));
            }
            add(frng.uniform(0, 2 * M_PI), M_PI / 2 - frng.uniform(0.05, 0.3));
        }
        const double r = std::max(rx, ry) * (planes.empty() ? 1.2 : 1.6);
        const int i0 = std::max(0, static_cast<int>((cx - r - x0_) / res_));
        const int i1 = std::min(nx_ - 1, static_cast<int>((cx + r - x0_) / res_) + 1);
        const int j0 = std::max(0, static_cast<int>((cy - r - y0_) / res_));
        const int j1 = std::min(ny_ - 1, static_cast<int>((cy + r - y0_) / res_) + 1);
        const double c = std::cos(rot), s = std::sin(rot);
        for (int j = j0; j <= j1; ++j) {
            for (int i = i0; i <= i1; ++i) {
                const double x = x0_ + i * res_ - cx, y = y0_ + j * res_ - cy;
                float hr = 0;
                if (planes.empty()) {
                    const double u = (c * x + s * y) / rx, v = (-s * x + c * y) / ry;
                    const double q = 1 - u * u - v * v;
                    if (q <= 0) continue;
                    // Casts turn with their bumps: noise in the rock's frame (world-aligned
                    // before molds existed, kept so for bit-identical presets).
                    const double bx = molds_ > 0 ? u * rx : x, by = molds_ > 0 ? v * ry : y;
                    const float bump = 0.85f + 0.3f * value_noise3(static_cast<float>(bx * 8), static_cast<float>(by * 8), 0, bump_seed);
                    hr = static_cast<float>(height_m * std::sqrt(q)) * bump;
                } else {
                    const double u = c * x + s * y, v = -s * x + c * y;  // metres, rock frame
                    double h = height_m * 1.5;
                    for (const auto& pl : planes) h = std::min(h, (pl.s - pl.nx * u - pl.ny * v) / pl.nz);
                    if (h <= 0) continue;
                    // Fine surface texture only: faces stay flat at the LRF scale.
                    const double bx = molds_ > 0 ? u : x, by = molds_ > 0 ? v : y;
                    hr = static_cast<float>(h) + 0.004f * (value_noise3(static_cast<float>(bx * 25), static_cast<float>(by * 25), 0, bump_seed) - 0.5f);
                }
                if (roughness_ > 0) {
                    // In the rock's own frame, so a turned cast keeps its relief.
                    const double ru = c * x + s * y, rv = -s * x + c * y;
                    hr += roughness_ * 2.f * (fbm2(static_cast<float>(ru / 0.08), static_cast<float>(rv / 0.08), bump_seed + 0x524fu, 2) - 0.5f);
                    if (hr <= 0) continue;
                }
                float& cell = h_[static_cast<std::size_t>(j) * nx_ + i];
                const float base = additive ? ground_[static_cast<std::size_t>(j) * nx_ + i] : 0.f;
                if (base + hr > cell) {
                    cell = base + hr;
                    mat_[static_cast<std::size_t>(j) * nx_ + i] = mat;
                }
            }
        }
    }

    // Max height over the 3x3 blocks around each block: a conservative bound for any
    // point within one block width, used to skip empty space while ray marching.
    void build_block_max() {
        block_ = lab_ ? 0.2 : 0.5;
        bn_ = static_cast<int>(std::ceil((nx_ - 1) * res_ / block_)) + 1;
        std::vector<float> bm(static_cast<std::size_t>(bn_) * bn_, -1e9f);
        for (int j = 0; j < ny_; ++j) {
            for (int i = 0; i < nx_; ++i) {
                const int bi = std::min(bn_ - 1, static_cast<int>(i * res_ / block_));
                const int bj = std::min(bn_ - 1, static_cast<int>(j * res_ / block_));
                float& m = bm[static_cast<std::size_t>(bj) * bn_ + bi];
                m = std::max(m, h_[static_cast<std::size_t>(j) * nx_ + i]);
            }
        }
        bmax_.assign(bm.size(), -1e9f);
        for (int bj = 0; bj < bn_; ++bj)
            for (int bi = 0; bi < bn_; ++bi)
                for (int dj = -1; dj <= 1; ++dj)
                    for (int di = -1; di <= 1; ++di) {
                        const int a = std::clamp(bi + di, 0, bn_ - 1), b = std::clamp(bj + dj, 0, bn_ - 1);
                        float& m = bmax_[static_cast<std::size_t>(bj) * bn_ + bi];
                        m = std::max(m, bm[static_cast<std::size_t>(b) * bn_ + a]);
                    }
    }
    double block_max(double x, double y) const {
        const int bi = std::clamp(static_cast<int>((x - x0_) / block_), 0, bn_ - 1);
        const int bj = std::clamp(static_cast<int>((y - y0_) / block_), 0, bn_ - 1);
        return bmax_[static_cast<std::size_t>(bj) * bn_ + bi];
    }

    // The moon's sun (the direction colour() shades with) is fixed in the world, so shadows are
    // too: a cell is in shadow when the height field rises above the ray from it towards the sun
    // (marched one cell at a time, up to 6 m: a 1 m rock's shadow at 31 degrees is 1.7 m).
    static Eigen::Vector3d moon_sun() { return Eigen::Vector3d(0.7, 0.3, 0.45).normalized(); }
    void build_shadows() {
        const Eigen::Vector3d sun = moon_sun();
        const double horiz = std::hypot(sun.x(), sun.y());
        const double dx = sun.x() / horiz * res_, dy = sun.y() / horiz * res_, dz = sun.z() / horiz * res_;
        const int steps = static_cast<int>(6.0 / res_);
        float top = -1e9f;
        for (const float h : h_) top = std::max(top, h);
        shadow_.assign(h_.size(), 0);
        for (int j = 0; j < ny_; ++j) {
            for (int i = 0; i < nx_; ++i) {
                const double x = x0_ + i * res_, y = y0_ + j * res_;
                double z = h_[static_cast<std::size_t>(j) * nx_ + i] + 0.01;
                for (int k = 1; k <= steps && z < top; ++k) {
                    z += dz;
                    if (height(x + k * dx, y + k * dy) > z) {
                        shadow_[static_cast<std::size_t>(j) * nx_ + i] = 1;
                        break;
                    }
                }
            }
        }
    }
    bool in_shadow(double x, double y) const {
        const int i = std::clamp(static_cast<int>(std::lround((x - x0_) / res_)), 0, nx_ - 1);
        const int j = std::clamp(static_cast<int>(std::lround((y - y0_) / res_)), 0, ny_ - 1);
        return shadow_[static_cast<std::size_t>(j) * nx_ + i] != 0;
    }

    void build_lab(const SimConfig& c, Rng& rng) {
        const float wall_h = 2.5f;
        for (int j = 0; j < ny_; ++j) {
            for (int i = 0; i < nx_; ++i) {
                const double x = x0_ + i * res_, y = y0_ + j * res_;
                const std::size_t k = static_cast<std::size_t>(j) * nx_ + i;
                if (x < 0 || y < 0 || x > size_ || y > size_) {
                    h_[k] = wall_h;
                    mat_[k] = kWall;
                } else {
                    h_[k] = 0.003f * value_noise3(static_cast<float>(x * 10), static_cast<float>(y * 10), 0, 3);
                }
            }
        }
        // A few furniture blocks along the walls (cupboards, a table-like step) for structure.
        for (int b = 0; b < 3; ++b) {
            const int side = static_cast<int>(rng.uniform() * 4);
            const double along = rng.uniform(1.0, size_ - 2.0), len = rng.uniform(0.6, 1.4);
            const double depth = rng.uniform(0.4, 0.6), hb = rng.uniform(0.5, 1.0);
            for (int j = 0; j < ny_; ++j) {
                for (int i = 0; i < nx_; ++i) {
                    const double x = x0_ + i * res_, y = y0_ + j * res_;
                    double a = 0, d = 0;
                    if (side == 0) { a = x; d = y; }
                    else if (side == 1) { a = x; d = size_ - y; }
                    else if (side == 2) { a = y; d = x; }
                    else { a = y; d = size_ - x; }
                    if (d >= 0 && d < depth && a > along && a < along + len) {
                        const std::size_t k = static_cast<std::size_t>(j) * nx_ + i;
                        h_[k] = static_cast<float>(hb);
                        mat_[k] = kWall;
                    }
                }
            }
            keep_out_.push_back({side >= 2 ? (side == 2 ? depth / 2 : size_ - depth / 2) : along + len / 2,
                                 side < 2 ? (side == 0 ? depth / 2 : size_ - depth / 2) : along + len / 2,
                                 std::max(len, depth) / 2 + 0.5});
        }
        ground_ = h_;
        const int n = c.rocks > 0 ? c.rocks : 15 + static_cast<int>(rng.uniform() * 16);
        for (int k = 0; k < n; ++k) {
            double d = rng.uniform(0.2, 0.8);  // diameter
            const double x = rng.uniform(0.8, size_ - 0.8), y = rng.uniform(0.8, size_ - 0.8);
            double aspect = rng.uniform(0.6, 1.0);
            // GCC evaluated stamp()'s arguments right to left before this was split up: height
            // first, then the turn, so presets stay bit-identical.
            double tall = rng.uniform(0.35, 0.6);
            const double rot = rng.uniform(0, M_PI);
            std::uint32_t shape = static_cast<std::uint32_t>(k + 100);
            if (c.rock_molds > 0) {
                // A cast keeps its mold's size, aspect, height and bumps; its own stream only
                // placed it, so the world's other draws are unchanged.
                const int mold = k % c.rock_molds;
                Rng mrng(mix(seed_, 0x4d4f4c44ull + static_cast<std::uint64_t>(mold)));
                d = mrng.uniform(0.2, 0.8);
                aspect = mrng.uniform(0.6, 1.0);
                tall = mrng.uniform(0.35, 0.6);
                shape = static_cast<std::uint32_t>(mold + 100);
            }
            const double rx = d / 2, ry = d / 2 * aspect;
            stamp(x, y, rx, ry, rot, d * tall, static_cast<std::uint16_t>(kRock + k), shape, true);
            keep_out_.push_back({x, y, rx + 0.4});
        }
    }

    void build_moon(const SimConfig& c, Rng& rng) {
        const auto s = static_cast<std::uint32_t>(seed_);
        for (int j = 0; j < ny_; ++j) {
            for (int i = 0; i < nx_; ++i) {
                const float x = static_cast<float>(x0_ + i * res_), y = static_cast<float>(y0_ + j * res_);
                h_[static_cast<std::size_t>(j) * nx_ + i] =
                    1.6f * (fbm2(x / 18.f, y / 18.f, s + 1, 3) - 0.5f) +
                    0.25f * (fbm2(x / 3.f, y / 3.f, s + 2, 3) - 0.5f) +
                    0.04f * (value_noise3(x * 2.5f, y * 2.5f, 0, s + 3) - 0.5f);
            }
        }
        // Craters: bowl with a raised rim, diameters 1..10 m, small ones more frequent.
        for (int k = 0; k < c.craters; ++k) {
            const double D = std::pow(10.0, rng.uniform() * rng.uniform());  // 1..10 m, mostly small
            const double cx = rng.uniform(-1, size_ + 1), cy = rng.uniform(-1, size_ + 1);
            const double R = D / 2, depth = 0.18 * D, rim = 0.05 * D;
            const double reach = 2.0 * R;
            const int i0 = std::max(0, static_cast<int>((cx - reach - x0_) / res_));
            const int i1 = std::min(nx_ - 1, static_cast<int>((cx + reach - x0_) / res_) + 1);
            const int j0 = std::max(0, static_cast<int>((cy - reach - y0_) / res_));
            const int j1 = std::min(ny_ - 1, static_cast<int>((cy + reach - y0_) / res_) + 1);
            for (int j = j0; j <= j1; ++j) {
                for (int i = i0; i <= i1; ++i) {
                    const double x = x0_ + i * res_ - cx, y = y0_ + j * res_ - cy;
                    const double r = std::sqrt(x * x + y * y) / R;
                    double dh = 0;
                    if (r < 1) dh = rim - (depth + rim) * (1 - r * r);
                    else if (r < 2) dh = rim * std::pow(2 - r, 2.0);
                    h_[static_cast<std::size_t>(j) * nx_ + i] += static_cast<float>(dh);
                }
            }
            if (D > 2.0) keep_out_.push_back({cx, cy, R + 0.8});
        }
        ground_ = h_;
        const int n = c.rocks > 0 ? c.rocks : static_cast<int>(90 * (size_ * size_) / 3600.0);
        for (int k = 0; k < n; ++k) {
            const double u = rng.uniform();
            double d = 0.2 + 1.3 * u * u;  // 0.2..1.5 m, mostly small
            if (c.rock_size_exponent > 0) {
                // Inverse CDF of the truncated power law N(>D) ~ D^-b on [rock_min_m, 1.5 m].
                const double b = c.rock_size_exponent, lo = std::min(c.rock_min_m, 1.5);
                d = lo * std::pow(1.0 - u * (1.0 - std::pow(lo / 1.5, b)), -1.0 / b);
            }
            const double x = rng.uniform(0, size_), y = rng.uniform(0, size_);
            const double rx = d / 2, ry = d / 2 * rng.uniform(0.6, 1.0);
            // GCC evaluated stamp()'s arguments right to left: the height is drawn first.
            const double tall = rng.uniform(0.3, 0.55);
            const double rot = rng.uniform(0, M_PI);
            // Material ids are 16 bit: rocks beyond 65 000 share ids (colour only).
            stamp(x, y, rx, ry, rot, d * tall, static_cast<std::uint16_t>(kRock + k % 65000),
                  static_cast<std::uint32_t>(k + 500), true);
            if (d * tall > c.rock_drive_over_m) keep_out_.push_back({x, y, rx + 0.6});
        }
    }

    bool lab_;
    std::uint64_t seed_;
    float rock_var_ = 1, floor_contrast_ = 1;
    int facets_ = 0;
    int molds_ = 0;
    float roughness_ = 0;
    double size_ = 0, res_ = 0, x0_ = 0, y0_ = 0;
    int nx_ = 0, ny_ = 0;
    std::vector<float> h_, ground_, bmax_;
    std::vector<std::uint8_t> shadow_;  // moon cells the sun does not reach (cast_shadows)
    double block_ = 0.2;
    int bn_ = 0;
    std::vector<std::uint16_t> mat_;
    std::vector<Disc> keep_out_;
};

// ---------------------------------------------------------------- rover

struct Pose2 {
    double x, y, yaw;
};

class PathPlanner {
public:
    // unstick: after a full turn on the spot the rover squeezes out (below).
    PathPlanner(const World& w, Rng& rng, double margin, double wander, bool unstick)
        : w_(w), rng_(rng), margin_(margin), wander_(wander), unstick_(unstick) {}

    Pose2 start() {
        for (int attempt = 0; attempt < 1000; ++attempt) {
            Pose2 p{rng_.uniform(margin_ + 0.5, w_.size() - margin_ - 0.5),
                    rng_.uniform(margin_ + 0.5, w_.size() - margin_ - 0.5), rng_.uniform(-M_PI, M_PI)};
            if (clearance(p.x, p.y) > 0.3) return p;
        }
        return {w_.size() / 2, w_.size() / 2, 0};
    }

    // Advances by `step` on a smooth curve that keeps away from walls, rocks and craters;
    // when every driveable arc is blocked, turns on the spot (skid steering).
    Pose2 advance(const Pose2& p, double step) {
        curvature_ += -0.15 * curvature_ + wander_ * rng_.normal();
        const double max_turn = step / 0.6;  // min turn radius 0.6 m while driving
        const double desired = std::clamp(curvature_ * step, -max_turn, max_turn);
        double best_score = -1e9, best_turn = 0, best_clear = -1e9;
        for (int k = -4; k <= 4; ++k) {
            const double turn = k * max_turn / 4;
            const double clear = clearance_along(p, p.yaw + turn, 1.2);
            const double score = std::min(clear, 0.6) * 5 - std::abs(turn - desired) / max_turn;
            if (score > best_score) {
                best_score = score;
                best_turn = turn;
                best_clear = clear;
            }
        }
        Pose2 q = p;
        // Boxed in for a full turn on the spot: the operator squeezes the rover out for 1.5 m,
        // passing closer to rocks than the usual margin. Without it a rover in a pocket between
        // rocks turned on the spot for a whole run.
        if (unstick_ && spot_frames_ > 18) squeeze_frames_ = 15;
        if (best_clear < (squeeze_frames_ > 0 ? -0.3 : 0.05)) {
            ++spot_frames_;
            // Spot turn towards the freest direction, at most 0.35 rad per frame.
            double free_dir = 0, free_clear = -1e9;
            for (int k = 1; k < 21; ++k) {
                const double turn = (k % 2 ? 1 : -1) * ((k + 1) / 2) * (M_PI / 10);
                const double clear = clearance_along(p, p.yaw + turn, 1.5);
                if (clear > free_clear + 1e-9) {
                    free_clear = clear;
                    free_dir = turn;
                }
            }
            q.yaw = std::remainder(p.yaw + std::clamp(free_dir, -0.35, 0.35), 2 * M_PI);
            curvature_ = 0;
            return q;
        }
        spot_frames_ = 0;
        if (squeeze_frames_ > 0) --squeeze_frames_;
        q.yaw = p.yaw + 0.5 * best_turn;
        q.x += step * std::cos(q.yaw);
        q.y += step * std::sin(q.yaw);
        q.yaw = std::remainder(p.yaw + best_turn, 2 * M_PI);
        return q;
    }

private:
    double clearance_along(const Pose2& p, double yaw, double length) const {
        double clear = 1e9;
        for (double d = 0.15; d <= length + 1e-9; d += 0.15) {
            clear = std::min(clear, clearance(p.x + d * std::cos(yaw), p.y + d * std::sin(yaw)));
        }
        return clear;
    }
    double clearance(double x, double y) const {
        double c = std::min({x - margin_, y - margin_, w_.size() - margin_ - x, w_.size() - margin_ - y});
        for (const auto& d : w_.keep_out()) c = std::min(c, std::hypot(x - d.x, y - d.y) - d.r);
        return c;
    }

    const World& w_;
    Rng& rng_;
    double margin_, wander_;
    double curvature_ = 0;
    bool unstick_ = false;
    int spot_frames_ = 0;     // consecutive turns on the spot
    int squeeze_frames_ = 0;  // driving steps left with the reduced clearance
};

Eigen::Isometry3d base_pose(const World& w, const Pose2& p) {
    // Roll and pitch follow the terrain under a 0.8 m x 0.7 m wheelbase.
    const double c = std::cos(p.yaw), s = std::sin(p.yaw);
    const double hf = w.height(p.x + 0.4 * c, p.y + 0.4 * s), hb = w.height(p.x - 0.4 * c, p.y - 0.4 * s);
    const double hl = w.height(p.x - 0.35 * s, p.y + 0.35 * c), hr = w.height(p.x + 0.35 * s, p.y - 0.35 * c);
    const double pitch = -std::atan2(hf - hb, 0.8), roll = std::atan2(hl - hr, 0.7);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(p.yaw, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(p.x, p.y, 0.25 * (hf + hb + hl + hr));
    return T;
}

Eigen::Matrix3d rpy(double roll, double pitch, double yaw) {
    return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
        .toRotationMatrix();
}

std::uint8_t to_byte(float v) { return static_cast<std::uint8_t>(std::clamp(std::lround(v * 255.f), 0L, 255L)); }

// Builds the submaps of one run and hands them to `rw`.
void simulate_run(const SimConfig& c, const World& world, int run, RunWriter& rw) {
    // Separate streams: the path and odometry do not change when the sensor model does.
    Rng rng(mix(c.seed, 1000 + static_cast<std::uint64_t>(run)));
    Rng sensor_rng(mix(c.seed, 5000 + static_cast<std::uint64_t>(run)));
    Rng exposure_rng(mix(c.seed, 9000 + static_cast<std::uint64_t>(run)));  // colours only
    PathPlanner planner(world, rng, world.lab() ? 0.7 : 6.0, c.path_wander, c.path_unstick != 0);
    Pose2 p2 = planner.start();
    Eigen::Isometry3d T_gt = base_pose(world, p2);
    Eigen::Isometry3d T_odom = T_gt;  // odometry starts at the true pose
    const double scale_bias = 1 + c.scale_bias_sigma * rng.normal();

    const double tan_h = std::tan(c.hfov_deg * M_PI / 360), tan_v = std::tan(c.vfov_deg * M_PI / 360);
    std::vector<Eigen::Vector3d> rays_cam;  // camera frame: x forward, y left, z up
    for (int v = 0; v < c.image_height; ++v) {
        for (int u = 0; u < c.image_width; ++u) {
            rays_cam.emplace_back(1, tan_h * (1 - 2 * (u + 0.5) / c.image_width),
                                  tan_v * (1 - 2 * (v + 0.5) / c.image_height));
        }
    }
    std::vector<StampedPose> gt_full, odom_full;
    int frame = 0;
    const double dt = 0.5;  // s per frame
    for (int sm = 0; sm < c.submaps; ++sm) {
        const Eigen::Isometry3d T_w_sub_gt = T_gt, T_w_sub_odom = T_odom;
        const double t0 = frame * dt;
        std::vector<ColoredPoint> raw;
        auto tree = std::make_shared<octomap::OcTree>(c.octomap_resolution_m);
        // Rays of all frames are merged into one free and one occupied key set and each
        // voxel is updated once: the same free/occupied/unknown classification as frame-
        // by-frame insertion (occupied wins), at a fraction of the cost.
        octomap::KeySet free_keys, occupied_keys;
        octomap::KeyRay key_ray;
        auto add_ray = [&](const Eigen::Vector3d& from, const Eigen::Vector3d& to, bool hit) {
            const octomap::point3d a(static_cast<float>(from.x()), static_cast<float>(from.y()), static_cast<float>(from.z()));
            const octomap::point3d b(static_cast<float>(to.x()), static_cast<float>(to.y()), static_cast<float>(to.z()));
            if (tree->computeRayKeys(a, b, key_ray)) free_keys.insert(key_ray.begin(), key_ray.end());
            octomap::OcTreeKey k;
            if (hit && tree->coordToKeyChecked(b, k)) occupied_keys.insert(k);
        };
        double dist = 0, var = 0;
        bool first = true;
        int frames_in_submap = 0;
        // Turning on the spot adds frames but no distance; cap the frames per submap.
        const int max_frames = static_cast<int>(2.5 * c.submap_distance_m / c.frame_step_m) + 1;
        while (first || (dist < c.submap_distance_m && std::sqrt(var) < c.submap_sigma_m &&
                         frames_in_submap < max_frames)) {
            ++frames_in_submap;
            if (!first) {
                // Drive one step: true motion, then odometry with noise on the increment.
                const Pose2 next = planner.advance(p2, c.frame_step_m);
                const Eigen::Isometry3d T_next = base_pose(world, next);
                const Eigen::Isometry3d inc = T_gt.inverse() * T_next;
                const double ds = inc.translation().head<2>().norm();
                const Eigen::Vector3d nz = world.normal(next.x, next.y);
                const double slope = std::sqrt(std::max(0.0, 1 - nz.z() * nz.z())) / std::max(nz.z(), 0.2);
                const double k = 1 + 2 * slope, sq = std::sqrt(ds);
                Eigen::Isometry3d noise = Eigen::Isometry3d::Identity();
                noise.translation() = Eigen::Vector3d((scale_bias - 1) * ds + k * c.sigma_x * sq * rng.normal(),
                                                      k * c.sigma_y * sq * rng.normal(), 0);
                noise.linear() = rpy(c.sigma_roll_pitch * sq * rng.normal(), c.sigma_roll_pitch * sq * rng.normal(),
                                     k * c.sigma_yaw * sq * rng.normal());
                T_odom = T_odom * inc * noise;
                T_gt = T_next;
                p2 = next;
                dist += ds;
                var += k * k * (c.sigma_x * c.sigma_x + c.sigma_y * c.sigma_y) * ds +
                       std::pow(dist * k * c.sigma_yaw * sq, 2);
            }
            first = false;
            gt_full.push_back({frame * dt, T_gt});
            odom_full.push_back({frame * dt, T_odom});
            // One depth frame at the current pan angle of the sweep.
            const double pan = c.pan_sweep_deg[frame % c.pan_sweep_deg.size()] * M_PI / 180;
            // Exposure of this frame, from its own stream: geometry does not depend on it.
            float gain[3] = {1.f, 1.f, 1.f};
            if (c.exposure_sigma > 0) {
                const double g = std::max(0.2, 1 + c.exposure_sigma * exposure_rng.normal());
                for (float& ch : gain) {
                    ch = static_cast<float>(g * std::max(0.2, 1 + c.exposure_sigma / 3 * exposure_rng.normal()));
                }
            }
            Eigen::Isometry3d T_base_cam = Eigen::Isometry3d::Identity();
            T_base_cam.translation() = Eigen::Vector3d(0, 0, c.camera_height_m);
            T_base_cam.linear() = rpy(0, -c.tilt_deg * M_PI / 180, pan);
            const Eigen::Isometry3d T_w_cam = T_gt * T_base_cam;
            // Points go into the submap frame through odometry, as on the robot.
            const Eigen::Isometry3d T_sub_cam = T_w_sub_odom.inverse() * T_odom * T_base_cam;
            for (int v = 0; v < c.image_height; ++v) {
                for (int u = 0; u < c.image_width; ++u) {
                    const Eigen::Vector3d& rc = rays_cam[static_cast<std::size_t>(v) * c.image_width + u];
                    const Eigen::Vector3d dir_w = (T_w_cam.linear() * rc).normalized();
                    const bool for_octomap = u % c.octomap_pixel_stride == 0 && v % c.octomap_pixel_stride == 0;
                    double t = 0;
                    const bool hit = world.raycast(T_w_cam.translation(), dir_w, c.max_range_m * 1.3, t);
                    const double depth = hit ? t / rc.norm() : 0;  // along the optical axis
                    if (!hit || depth > c.max_range_m) {
                        if (for_octomap) {
                            // No return within range: free up to the range limit, no more.
                            const Eigen::Vector3d e = T_sub_cam * (rc.normalized() * c.max_range_m);
                            add_ray(T_sub_cam.translation(), e, false);
                        }
                        continue;
                    }
                    const Eigen::Vector3d p_w = T_w_cam.translation() + t * dir_w;
                    if (sensor_rng.uniform() < c.hole_probability || world.stereo_hole(p_w)) continue;
                    // Stereo depth noise: sigma_z = z^2 sigma_d / (f b).
                    const double sigma_z = depth * depth * c.disparity_sigma_px / (c.focal_px * c.baseline_m);
                    const double z_noisy = depth + sigma_z * sensor_rng.normal();
                    const Eigen::Vector3d p_sub = T_sub_cam * (rc * z_noisy);
                    Rgb col = world.colour(p_w);
                    col.r *= gain[0];
                    col.g *= gain[1];
                    col.b *= gain[2];
                    ColoredPoint q;
                    q.x = static_cast<float>(p_sub.x());
                    q.y = static_cast<float>(p_sub.y());
                    q.z = static_cast<float>(p_sub.z());
                    q.r = to_byte(col.r);
                    q.g = to_byte(col.g);
                    q.b = to_byte(col.b);
                    raw.push_back(q);
                    if (for_octomap) add_ray(T_sub_cam.translation(), p_sub, true);
                }
            }
            ++frame;
        }
        // Sorted keys: the tree (and its .bt bytes) must not depend on hash-set order.
        std::vector<octomap::OcTreeKey> occ(occupied_keys.begin(), occupied_keys.end()), fre;
        for (const auto& k : free_keys) {
            if (!occupied_keys.count(k)) fre.push_back(k);
        }
        auto less = [](const octomap::OcTreeKey& a, const octomap::OcTreeKey& b) {
            return std::make_tuple(a[0], a[1], a[2]) < std::make_tuple(b[0], b[1], b[2]);
        };
        std::sort(occ.begin(), occ.end(), less);
        std::sort(fre.begin(), fre.end(), less);
        for (const auto& k : fre) tree->updateNode(k, false, true);
        for (const auto& k : occ) tree->updateNode(k, true, true);
        tree->updateInnerOccupancy();
        tree->prune();
        Submap s;
        s.cloud = voxel_filter(raw, static_cast<float>(c.voxel_m));
        if (s.cloud.empty()) {  // looking into the void (should not happen in these worlds)
            ColoredPoint q;
            s.cloud.push_back(q);
        }
        // Obstacles in the gravity-aligned submap frame (the robot knows gravity from its IMU).
        const Eigen::Matrix3d R = T_w_sub_odom.linear();
        const double yaw = std::atan2(R(1, 0), R(0, 0));
        const Eigen::Matrix3f R_g = (Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R).cast<float>();
        std::vector<ColoredPoint> leveled = s.cloud;
        for (auto& q : leveled) {
            const Eigen::Vector3f v = R_g * Eigen::Vector3f(q.x, q.y, q.z);
            q.x = v.x(); q.y = v.y(); q.z = v.z();
        }
        HeightObstacleSettings hs;
        hs.cell = static_cast<float>(std::max(0.1, 2.5 * c.voxel_m));
        hs.step = world.lab() ? 0.1f : 0.15f;
        hs.negative_drop = world.lab() ? 0.15f : 0.25f;
        hs.max_height = static_cast<float>(c.obstacle_max_height_m);
        if (c.obstacle_top_surface) {
            hs.top_surface_cell = static_cast<float>(c.obstacle_cell_m > 0 ? c.obstacle_cell_m : c.voxel_m);
        }
        for (const auto& v : detect_obstacles_height(leveled, hs)) s.obstacles.push_back(R_g.transpose() * v);
        s.octree = tree;
        s.T_world_submap_gt = T_w_sub_gt;
        s.T_world_submap_odom = T_w_sub_odom;
        rw.add_submap(s, t0);
    }
    rw.set_full_trajectories(std::move(gt_full), std::move(odom_full));
    rw.finish();
}

// The seed of world w of SimConfig::worlds: world 0 is the seed's own (a dataset of one world
// is what it was before the setting existed).
std::uint64_t world_seed(const SimConfig& config, int w) {
    return w == 0 ? config.seed : mix(config.seed, 0x53495445ull + static_cast<std::uint64_t>(w));
}

}  // namespace

HeightMapImage world_height_map(const SimConfig& config, double resolution) {
    return World(config, config.seed).height_map(resolution);
}

std::string generate_dataset(const SimConfig& c, const fs::path& out, bool overwrite,
                             const std::function<void(const GenerateProgress&)>& progress) {
    if (c.runs < 1 || c.runs > 1000) throw std::invalid_argument("--runs must be in [1, 1000]");
    if (c.submaps < 1 || c.submaps > 1000) throw std::invalid_argument("--submaps must be in [1, 1000]");
    if (c.pan_sweep_deg.empty()) throw std::invalid_argument("pan sweep must not be empty");
    if (c.worlds < 1 || c.worlds > c.runs) {
        throw std::invalid_argument("--sim worlds: " + std::to_string(c.worlds) + " for " + std::to_string(c.runs) +
                                    " runs (worlds must be in [1, runs])");
    }
    std::vector<World> worlds;
    worlds.reserve(static_cast<std::size_t>(c.worlds));
    for (int w = 0; w < c.worlds; ++w) worlds.emplace_back(c, world_seed(c, w));
    DatasetWriter writer(out, c.world, "simulator", c.voxel_m, std::max(0.2, 4 * c.voxel_m), overwrite);
    writer.set_meta("world", c.world);
    writer.set_meta("seed", std::to_string(c.seed));
    writer.set_meta("runs", std::to_string(c.runs));
    writer.set_meta("submaps", std::to_string(c.submaps));
    writer.set_meta("world_size_m", std::to_string(c.world_size));
    writer.set_meta("max_range_m", std::to_string(c.max_range_m));
    writer.set_meta("octomap_resolution_m", std::to_string(c.octomap_resolution_m));
    writer.set_meta("image", std::to_string(c.image_width) + "x" + std::to_string(c.image_height));
    writer.set_meta("submap_distance_m", std::to_string(c.submap_distance_m));
    writer.set_meta("obstacle_max_height_m", std::to_string(c.obstacle_max_height_m));
    writer.set_meta("obstacle_top_surface", c.obstacle_top_surface ? "true" : "false");
    std::string all;
    for (const auto& kv : sim_options(c)) all += (all.empty() ? "" : " ") + kv;
    writer.set_meta("sim", all);  // every setting, so a dataset documents how it was made
    std::atomic<int> next{0}, done{0};
    std::mutex progress_mutex;
    std::exception_ptr error;
    auto worker = [&]() {
        for (int r = next++; r < c.runs; r = next++) {
            try {
                RunWriter rw = writer.run(r);
                simulate_run(c, worlds[static_cast<std::size_t>(r % c.worlds)], r, rw);
                std::lock_guard<std::mutex> lock(progress_mutex);
                ++done;
                // May throw to cancel (SIGINT): the writer then removes its temporary directory.
                if (progress) progress({done.load(), c.runs});
            } catch (...) {
                std::lock_guard<std::mutex> lock(progress_mutex);
                if (!error) error = std::current_exception();
                next = c.runs;
                return;
            }
        }
    };
    int n_threads = c.threads > 0 ? c.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    n_threads = std::min(n_threads, c.runs);
    std::vector<std::thread> pool;
    for (int i = 1; i < n_threads; ++i) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();
    if (error) std::rethrow_exception(error);
    return writer.finish();
}

}  // namespace maptune::dataset
