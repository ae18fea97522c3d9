#ifdef MAPTUNE_HAVE_DATASET
// `maptune dataset generate|info|import|render`: a thin front-end over libs/dataset.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <iostream>

#include "commands.hpp"
#include "dataset/dataset.hpp"
#include "dataset/importer.hpp"
#include "dataset/render.hpp"
#include "dataset/simulator.hpp"
#include "params/cli_range.hpp"

namespace maptune::cli {
namespace fs = std::filesystem;
namespace ds = maptune::dataset;

namespace {

// Set by SIGINT/SIGTERM while generate or import writes a dataset.
std::atomic<bool> g_interrupted{false};
void catch_interrupts() {
    std::signal(SIGINT, [](int) { g_interrupted = true; });
    std::signal(SIGTERM, [](int) { g_interrupted = true; });
}

// Runs `body`, mapping bad input to exit code 2 and other failures to 1.
template <typename F>
void guarded(int& exit_code, F&& body) {
    try {
        exit_code = body();
    } catch (const ds::DatasetError& e) {
        std::cerr << "error: " << e.what() << "\n";
        exit_code = 2;
    } catch (const std::invalid_argument& e) {
        std::cerr << "error: " << e.what() << "\n";
        exit_code = 2;
    } catch (const std::exception& e) {
        std::cerr << "error: " << e.what() << "\n";
        exit_code = 1;
    }
}

std::vector<fs::path> expand_clouds(const std::vector<std::string>& args) {
    std::vector<fs::path> out;
    for (const auto& a : args) {
        if (fs::is_directory(a)) {
            std::vector<fs::path> dir;
            for (const auto& e : fs::directory_iterator(a)) {
                const auto ext = e.path().extension().string();
                if (ext == ".pcd" || ext == ".ply" || ext == ".PCD" || ext == ".PLY") dir.push_back(e.path());
            }
            if (dir.empty()) throw ds::DatasetError(a, "directory holds no .pcd or .ply clouds");
            std::sort(dir.begin(), dir.end());
            out.insert(out.end(), dir.begin(), dir.end());
        } else {
            if (!fs::exists(a)) throw ds::DatasetError(a, "missing cloud file");
            out.emplace_back(a);
        }
    }
    return out;
}

nlohmann::json to_json(const ds::MeanStd& m) {
    return {{"mean", m.mean}, {"std", m.std}, {"min", m.min}, {"max", m.max}, {"n", m.n}};
}

}  // namespace

void add_dataset_command(CLI::App& app, int& exit_code) {
    auto* cmd = app.add_subcommand("dataset", "Robot datasets: simulate, import, inspect, render");
    cmd->require_subcommand(1);

    // ---------------------------------------------------------------- generate
    struct GenOpts {
        std::string preset, world, out;
        int runs = -1, submaps = -1, threads = 0;
        double obstacle_max_height = -1;
        std::vector<std::string> sim;  // KEY=VALUE overrides of the preset
        std::uint64_t seed = 1;
        bool force = false;
    };
    auto g = std::make_shared<GenOpts>();
    auto* gen = cmd->add_subcommand("generate", "Simulate a rover dataset (lab or moon world)");
    gen->add_option("--preset", g->preset,
                    "lab (13 runs x 15 submaps), moon (40 x 40), lab-tiny, moon-tiny (2 x 4, for tests); "
                    "default: the --world's preset, else lab");
    gen->add_option("--world", g->world, "lab | moon; default: the preset's world");
    gen->add_option("--runs", g->runs, "runs, 1..1000; default: the preset's")->check(CLI::Range(1, 1000));
    gen->add_option("--submaps", g->submaps, "submaps per run, 1..1000; default: the preset's")
        ->check(CLI::Range(1, 1000));
    gen->add_option("--seed", g->seed, "world and trajectory seed, any 64-bit integer; default 1");
    gen->add_option("--threads", g->threads, "worker threads, 0..256 (0 = all cores); default 0; "
                    "output does not depend on it")->check(CLI::Range(0, 256));
    gen->add_option("--out", g->out, "output dataset directory (must not exist unless --force)")->required();
    gen->add_option("--obstacle-max-height", g->obstacle_max_height,
                    "obstacle points only up to this height above the ground [m], 0..10 (0 = no limit); "
                    "default 0.6")
        ->check(maptune::params::finite_range(0.0, 10.0));
    gen->add_option("--sim", g->sim,
                    "simulator setting KEY=VALUE over the preset (repeatable), e.g. world_size=12, "
                    "max_range_m=5, pan_sweep_deg=-45,0,45; docs/datasets.md lists them");
    gen->add_flag("--force", g->force, "replace an existing output directory");
    gen->callback([g, &exit_code]() {
        guarded(exit_code, [&]() {
            std::string preset = g->preset;
            if (preset.empty()) preset = g->world.empty() ? "lab" : g->world;
            ds::SimConfig c = ds::sim_preset(preset);
            if (!g->world.empty() && g->world != c.world) {
                if (g->world != "lab" && g->world != "moon") {
                    throw std::invalid_argument("unknown world '" + g->world + "' (lab|moon)");
                }
                throw std::invalid_argument("--world " + g->world + " contradicts --preset " + preset);
            }
            if (g->runs > 0) c.runs = g->runs;
            if (g->submaps > 0) c.submaps = g->submaps;
            if (g->obstacle_max_height >= 0) c.obstacle_max_height_m = g->obstacle_max_height;
            for (const auto& kv : g->sim) {
                const auto eq = kv.find('=');
                if (eq == std::string::npos) throw std::invalid_argument("--sim " + kv + ": expected KEY=VALUE");
                if (auto err = ds::set_sim_option(c, kv.substr(0, eq), kv.substr(eq + 1)); !err.empty()) {
                    throw std::invalid_argument(err);
                }
            }
            c.seed = g->seed;
            c.threads = g->threads;
            const auto t0 = std::chrono::steady_clock::now();
            // SIGINT/SIGTERM end the generation after the runs in progress, and the half-written
            // temporary directory is removed (the default action left <out>.tmp-PID-N behind).
            catch_interrupts();
            const std::string id = ds::generate_dataset(c, g->out, g->force, [](const ds::GenerateProgress& p) {
                if (g_interrupted) throw std::runtime_error("interrupted: nothing written");
                std::cerr << "\rruns " << p.runs_done << "/" << p.runs_total << std::flush;
            });
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            std::cerr << "\n";
            std::cout << "wrote " << g->out << " (" << preset << ", " << c.runs << " runs x " << c.submaps
                      << " submaps, seed " << c.seed << ") id " << id << " in " << s << " s\n";
            return 0;
        });
    });

    // ---------------------------------------------------------------- info
    struct InfoOpts {
        std::string dir;
        bool json = false, verify = false;
        double threshold = 0.1;
    };
    auto in = std::make_shared<InfoOpts>();
    auto* info = cmd->add_subcommand("info", "Statistics of a dataset (submaps, points, size d, overlap, odometry error)");
    info->add_option("dir", in->dir, "dataset directory")->required();
    info->add_flag("--json", in->json, "print JSON instead of text");
    info->add_flag("--verify", in->verify, "recompute the content hash from the files");
    info->add_option("--overlap-threshold", in->threshold,
                     "a pair overlaps when its gt overlap ratio exceeds this, 0..1; default 0.1")
        ->check(maptune::params::finite_range(0.0, 1.0));
    info->callback([in, &exit_code]() {
        guarded(exit_code, [&]() {
            const auto d = ds::Dataset::open(in->dir);
            const auto s = ds::compute_stats(d, in->threshold);
            bool ok = true;
            std::string recomputed;
            if (in->verify) ok = d.verify(&recomputed);
            if (in->json) {
                nlohmann::json j = {{"id", d.manifest().id},
                                    {"name", d.manifest().name},
                                    {"runs", s.runs},
                                    {"submaps", s.submaps},
                                    {"submaps_per_run", to_json(s.submaps_per_run)},
                                    {"points_per_submap", to_json(s.points_per_submap)},
                                    {"obstacles_per_submap", to_json(s.obstacles_per_submap)},
                                    {"submap_size_m", to_json(s.submap_size)},
                                    {"complete_pairs", s.complete_pairs},
                                    {"overlap_threshold", s.overlap_threshold},
                                    {"overlapping_fraction", s.overlapping_fraction},
                                    {"subsequent_overlap", to_json(s.subsequent_overlap)},
                                    {"odometry_translation_error_m", to_json(s.odom_translation_error)},
                                    {"odometry_rotation_error_rad", to_json(s.odom_rotation_error)}};
                if (in->verify) j["verified"] = ok;
                std::cout << j.dump(2) << "\n";
            } else {
                std::cout << ds::format_stats(d, s);
                if (in->verify) std::cout << "content hash " << (ok ? "verified" : "MISMATCH: files hash to " + recomputed) << "\n";
            }
            if (!ok) {
                std::cerr << "error: " << in->dir << "/manifest.yaml: id does not match the files (modified dataset)\n";
                return 2;
            }
            return 0;
        });
    });

    // ---------------------------------------------------------------- import
    struct ImpOpts {
        std::vector<std::string> clouds, obstacles, octomaps;
        std::string poses, odometry, out, bunny, write_tum, name, method;
        double voxel = -1, octomap_res = -1, max_range = -1, curv_radius = -1;
        std::vector<float> origin;
        bool drop_nan = false, force = false;
    };
    auto im = std::make_shared<ImpOpts>();
    auto* imp = cmd->add_subcommand("import", "Real scans (PCD/PLY clouds + TUM poses) -> dataset of one run");
    imp->add_option("--clouds", im->clouds, "cloud files or directories (sorted .pcd/.ply), one submap each");
    imp->add_option("--poses", im->poses, "TUM file, one ground-truth pose T_world_cloud per cloud, in order");
    imp->add_option("--odometry", im->odometry, "TUM file of odometry poses (default: copy of --poses)");
    imp->add_option("--obstacles", im->obstacles, "obstacle point files, one per cloud (default: derived)");
    imp->add_option("--octomaps", im->octomaps, "OctoMap .bt files, one per cloud (default: built from rays)");
    imp->add_option("--bunny", im->bunny, "import the Stanford bunny scans in this directory (uses bun.conf)");
    imp->add_option("--write-tum", im->write_tum, "also write the poses used (e.g. converted bun.conf) as TUM here");
    imp->add_option("--name", im->name, "dataset name; default 'import' (bunny: stanford-bunny)");
    imp->add_option("--voxel", im->voxel, "cloud voxel size [m], 0.0001..10; default 0.05 (bunny 0.002)")
        ->check(maptune::params::finite_range(0.0001, 10.0));
    imp->add_option("--octomap-resolution", im->octomap_res, "[m], 0.001..10; default 0.1 (bunny 0.004)")
        ->check(maptune::params::finite_range(0.001, 10.0));
    imp->add_option("--max-range", im->max_range, "OctoMap ray length limit [m], <=0 unlimited; default unlimited");
    imp->add_option("--sensor-origin", im->origin, "sensor origin x y z in each cloud's frame [m]; default 0 0 0 (bunny 0 0 0.25)")
        ->expected(3);
    imp->add_option("--obstacle-method", im->method, "curvature | height (gravity-aligned ground data); default curvature")
        ->check(CLI::IsMember({"curvature", "height"}));
    imp->add_option("--curvature-radius", im->curv_radius, "[m], 0.0001..10; default 0.15 (bunny 0.006)")
        ->check(maptune::params::finite_range(0.0001, 10.0));
    imp->add_flag("--drop-nan", im->drop_nan, "drop NaN/Inf points instead of rejecting the cloud");
    imp->add_option("--out", im->out, "output dataset directory (must not exist unless --force)")->required();
    imp->add_flag("--force", im->force, "replace an existing output directory");
    imp->callback([im, &exit_code]() {
        guarded(exit_code, [&]() {
            ds::ImportInput input;
            ds::ImportOptions o;
            if (!im->bunny.empty()) {
                if (!im->clouds.empty() || !im->poses.empty()) {
                    throw std::invalid_argument("--bunny excludes --clouds and --poses");
                }
                input = ds::read_bunny_conf(fs::path(im->bunny) / "bun.conf");
                o = ds::bunny_options();
            } else {
                if (im->clouds.empty() || im->poses.empty()) {
                    throw std::invalid_argument("import needs --clouds and --poses (or --bunny DIR)");
                }
                input.clouds = expand_clouds(im->clouds);
                input.poses = ds::read_poses_for(im->poses, input.clouds.size());
            }
            if (!im->odometry.empty()) input.odometry = ds::read_poses_for(im->odometry, input.clouds.size());
            for (const auto& f : im->obstacles) input.obstacles.emplace_back(f);
            for (const auto& f : im->octomaps) input.octomaps.emplace_back(f);
            if (!im->name.empty()) o.name = im->name;
            if (im->voxel > 0) o.voxel_m = im->voxel;
            if (im->octomap_res > 0) o.octomap_resolution_m = im->octomap_res;
            if (im->max_range > 0) o.max_range_m = im->max_range;
            if (im->origin.size() == 3) o.sensor_origin = Eigen::Vector3f(im->origin[0], im->origin[1], im->origin[2]);
            if (!im->method.empty()) o.obstacle_method = im->method;
            if (im->curv_radius > 0) o.curvature_radius_m = im->curv_radius;
            o.drop_nan = im->drop_nan;
            o.overwrite = im->force;
            // As generate: an interrupted import stops before the next cloud and leaves nothing.
            catch_interrupts();
            o.interrupted = [] { return g_interrupted.load(); };
            const std::string id = ds::import_dataset(input, o, im->out);
            // Only after the import succeeded: a failed import leaves no half of its outputs.
            if (!im->write_tum.empty()) ds::write_file(im->write_tum, ds::format_tum(input.poses));
            std::cout << "wrote " << im->out << " (" << input.clouds.size() << " submaps) id " << id << "\n";
            return 0;
        });
    });

    // ---------------------------------------------------------------- render
    struct RenderOpts {
        std::string dir, out, submap;
        int run = 0, width = 1000;
    };
    auto ro = std::make_shared<RenderOpts>();
    auto* ren = cmd->add_subcommand("render", "PNG: top-down view of a run, or one submap with its obstacle points");
    ren->add_option("dir", ro->dir, "dataset directory")->required();
    ren->add_option("--run", ro->run, "run index for the top-down view, 0..runs-1; default 0");
    ren->add_option("--submap", ro->submap, "render this submap id (e.g. run00/submap003) instead of a run");
    ren->add_option("--width", ro->width, "image width [px], 100..8000; default 1000")->check(CLI::Range(100, 8000));
    ren->add_option("--out", ro->out, "PNG file to write")->required();
    ren->callback([ro, &exit_code]() {
        guarded(exit_code, [&]() {
            const auto d = ds::Dataset::open(ro->dir);
            if (!ro->submap.empty()) {
                ds::write_png(ro->out, ds::render_submap(d.load_submap(ro->submap), ro->width, ro->width * 3 / 4));
            } else {
                if (ro->run < 0 || ro->run >= static_cast<int>(d.manifest().runs.size())) {
                    throw std::invalid_argument("--run " + std::to_string(ro->run) + " out of range (dataset has " +
                                                std::to_string(d.manifest().runs.size()) + " runs)");
                }
                ds::write_png(ro->out, ds::render_run_topdown(d, ro->run, ro->width));
            }
            std::cout << "wrote " << ro->out << "\n";
            return 0;
        });
    });
}

}  // namespace maptune::cli
#endif
