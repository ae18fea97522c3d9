#pragma once
// Rover simulator: deterministic worlds (moon-like terrain, lab with rocks), a rover with a
// stereo camera on a pan-tilt unit, drifting odometry, and submaps built like on the DLR
// LRU (SPEC §4). Model and constants: docs/datasets.md.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace maptune::dataset {

struct SimConfig {
    std::string world = "lab";      // lab | moon
    int runs = 13;
    int submaps = 15;               // per run
    std::uint64_t seed = 1;
    double world_size = 8.0;        // side of the square world [m]
    int rocks = 0;                  // 0 = world default (lab: 15..30, moon: ~90)
    int craters = 60;               // moon only
    // Sites: run r drives in world r mod `worlds` (world 0 is the seed's own, the others are
    // drawn from the seed), as a robot team records at several sites; views pair submaps
    // within a run only, so a tuning view then spans several worlds. 1 = every run in one world.
    int worlds = 1;
    // Lab appearance. Per-rock colour: 1 = each rock its own brown/red tint, 0 = all rocks of
    // one material (artificial rocks cast from one mix). Floor: 1 = carpet tiles with per-tile
    // tint and dark seams, 0 = a uniform floor (speckle only).
    double rock_colour_variation = 1.0;
    double floor_tile_contrast = 1.0;
    // Rock shape (both worlds): 0 = smooth bumpy caps; N >= 3 = angular rocks, convex polyhedra
    // of N side facets, N/2 + 1 shoulder facets and a top around the same half-ellipsoid.
    int rock_facets = 0;
    // Rock molds: 0 = every rock its own shape; N >= 1 = rocks cast from N molds, so rocks of
    // one mold share size and shape and differ only in where they lie and how they are turned
    // (a lab's artificial rocks are casts; twins make local descriptors ambiguous).
    int rock_molds = 0;
    // Rock surface roughness: amplitude [m] of fractal relief with wavelengths of ~8 cm and
    // ~4 cm on every rock (rough cast or natural stone); 0 = smooth (the presets).
    double rock_roughness_m = 0.0;
    // Moon rock sizes: 0 = diameters 0.2..1.5 m, mostly small (d = 0.2 + 1.3 u^2); b > 0 = a
    // power-law size-frequency distribution N(>D) ~ D^-b between rock_min_m and 1.5 m, the
    // shape measured for lunar rock populations (b ~ 2..2.5): many pebbles, few boulders.
    double rock_size_exponent = 0.0;
    double rock_min_m = 0.2;
    // Rocks at most this high [m] are driven over instead of avoided (0 = avoid every rock).
    double rock_drive_over_m = 0.0;
    // Moon: 1 = the low sun casts shadows (terrain and rocks shadow what lies behind them, lit
    // only by the ambient term), 0 = Lambertian shading alone (what the moon had before).
    int cast_shadows = 0;

    // Camera: a stereo pair (baseline_m) on a pan-tilt unit at camera_height_m. Rays are
    // cast on a subsampled image; the noise uses the real camera's focal length.
    int image_width = 112, image_height = 84;
    double hfov_deg = 64, vfov_deg = 48;
    double baseline_m = 0.09;
    double focal_px = 900;          // of the full-resolution camera, for stereo noise
    double disparity_sigma_px = 0.25;
    double camera_height_m = 1.0;
    double tilt_deg = -28;
    std::vector<double> pan_sweep_deg = {-60, -30, 0, 30, 60, 30, 0, -30};
    double max_range_m = 5.0;
    double hole_probability = 0.03; // random missing pixels; textureless patches add more
    // Auto exposure / white balance: per frame a brightness gain N(1, exposure_sigma) and a
    // per-channel gain N(1, exposure_sigma / 3) scale the colours (a camera panning between
    // bright walls and dark floor re-exposes). 0 = fixed exposure (the presets so far).
    double exposure_sigma = 0.0;

    // Rover and submaps.
    double frame_step_m = 0.1;      // distance driven between frames
    double path_wander = 0.1;       // curvature noise per frame [1/m]; stationary std ~2x this
    // 1: a rover boxed in between rocks for a full turn on the spot squeezes out (passing closer
    // than the usual clearance); 0: it may turn on the spot for the rest of the run.
    int path_unstick = 0;
    double submap_distance_m = 1.2; // new submap after this distance...
    double submap_sigma_m = 0.06;   // ...or when the predicted odometry std exceeds this
    double voxel_m = 0.04;          // cloud resolution
    double octomap_resolution_m = 0.05;
    int octomap_pixel_stride = 2;   // rays used for the OctoMap: every n-th pixel in u and v
    double obstacle_max_height_m = 0.6;  // obstacle points only this high above the ground
    bool obstacle_top_surface = true;     // one obstacle point per grid-map column, the highest
    // Column size of that rule: the rover's obstacle grid map has its own resolution, not the
    // cloud's; 0 = the cloud voxel (what it was before this setting existed).
    double obstacle_cell_m = 0.0;

    // Odometry noise: std grows with sqrt(distance); multiplied by (1 + 2 |slope|).
    double sigma_x = 0.03;          // [m/sqrt(m)]
    double sigma_y = 0.02;          // [m/sqrt(m)]
    double sigma_yaw = 0.012;       // [rad/sqrt(m)]
    double sigma_roll_pitch = 0.002;  // [rad/sqrt(m)]
    double scale_bias_sigma = 0.01; // per-run wheel scale error (systematic)

    int threads = 0;                // 0 = hardware concurrency; output does not depend on it
};

// Sets one numeric field of SimConfig by name ("world_size", "max_range_m", "voxel_m", ...;
// "pan_sweep_deg" takes a comma-separated list), for `dataset generate --sim KEY=VALUE`.
// Returns an error naming the key and value ("" when set); unknown keys list the known ones.
std::string set_sim_option(SimConfig& config, const std::string& key, const std::string& value);
// Every settable field as "key=value", in name order (written to the manifest's meta).
std::vector<std::string> sim_options(const SimConfig& config);

// Why a simulated dataset's manifest `meta` (world, seed, runs, submaps, sim) does not
// describe what `config` would generate: "" when it does, else the first differing setting
// and how many differ ("rocks: the dataset has 0, the settings ask for 600 (and 6 more)").
// A setting missing from an older manifest is compared with its default (new settings
// default to the old behaviour).
std::string sim_settings_mismatch(const SimConfig& config, const std::map<std::string, std::string>& meta);

// Presets "lab" (13 runs x 15 submaps) and "moon" (40 x 40); "lab-tiny" and "moon-tiny"
// for tests. Throws std::invalid_argument naming the preset when unknown.
SimConfig sim_preset(const std::string& name);
std::vector<std::string> sim_preset_names();

struct GenerateProgress {
    int runs_done = 0, runs_total = 0;
};
// Writes the dataset to `out` (atomically: temp dir, then rename); returns its id. `progress`
// is called after each run and may throw to cancel: nothing is left behind.
std::string generate_dataset(const SimConfig& config, const std::filesystem::path& out,
                             bool overwrite = false,
                             const std::function<void(const GenerateProgress&)>& progress = {});

// Top-down height map (row-major, ny rows of nx, metres) of the world, for plots.
struct HeightMapImage {
    int nx = 0, ny = 0;
    double x0 = 0, y0 = 0, resolution = 0;
    std::vector<float> height;
};
HeightMapImage world_height_map(const SimConfig& config, double resolution);

}  // namespace maptune::dataset
