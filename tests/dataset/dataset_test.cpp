// Dataset format, loader and views, simulator determinism, import (incl. the real
// Stanford bunny scans), bad input. Tiny worlds keep the suite fast.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <set>

#include "dataset/dataset.hpp"
#include "dataset/geometry.hpp"
#include "dataset/importer.hpp"
#include "dataset/io.hpp"
#include "dataset/render.hpp"
#include "dataset/simulator.hpp"

namespace fs = std::filesystem;
using namespace maptune::dataset;

namespace {

fs::path temp_root() {
    static const fs::path root = [] {
        fs::path p = fs::temp_directory_path() / ("maptune_dataset_test_" + std::to_string(::getpid()));
        fs::remove_all(p);
        fs::create_directories(p);
        return p;
    }();
    return root;
}

struct Cleanup : ::testing::Environment {
    void TearDown() override { fs::remove_all(temp_root()); }
};
const auto* const g_cleanup = ::testing::AddGlobalTestEnvironment(new Cleanup);

// Submap 1 of the dataset `c` generates into temp_root() / name (the recolouring tests).
Submap second_submap(const SimConfig& c, const std::string& name) {
    generate_dataset(c, temp_root() / name);
    return Dataset::open(temp_root() / name).load_submap(0, 1);
}

// The same points in the same order, whatever their colours.
void expect_same_points(const Submap& a, const Submap& b) {
    ASSERT_EQ(a.cloud.size(), b.cloud.size());
    for (std::size_t i = 0; i < a.cloud.size(); ++i) {
        EXPECT_EQ(a.cloud[i].x, b.cloud[i].x);
        EXPECT_EQ(a.cloud[i].z, b.cloud[i].z);
    }
}

// One shared tiny lab dataset (generated once for the whole suite).
const fs::path& lab_tiny() {
    static const fs::path p = [] {
        fs::path out = temp_root() / "lab_tiny";
        SimConfig c = sim_preset("lab-tiny");
        c.threads = 2;
        generate_dataset(c, out);
        return out;
    }();
    return p;
}

template <typename F>
std::string error_of(F&& f) {
    try {
        f();
    } catch (const DatasetError& e) {
        return e.what();
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "";
}

std::map<std::string, std::string> all_files(const fs::path& dir) {
    std::map<std::string, std::string> out;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (e.is_regular_file()) out[fs::relative(e.path(), dir).string()] = read_file(e.path());
    }
    return out;
}

void put(const fs::path& p, const std::string& s) { std::ofstream(p, std::ios::binary | std::ios::trunc) << s; }

}  // namespace

TEST(SimulatorTest, SameSeedGivesByteIdenticalDatasetWhateverTheThreads) {
    SimConfig c = sim_preset("lab-tiny");
    c.threads = 1;
    const fs::path a = temp_root() / "det_a";
    const std::string id_a = generate_dataset(c, a);
    const std::string id_b = Dataset::open(lab_tiny()).manifest().id;  // 2 threads
    EXPECT_EQ(id_a, id_b);
    EXPECT_EQ(all_files(a), all_files(lab_tiny()));
    c.seed = 2;
    EXPECT_NE(generate_dataset(c, temp_root() / "det_c"), id_a);
}

// Issue 14: `--out . --force` emptied the current directory. --force replaces only a previous
// dataset: never the current directory (or one holding it), a file, or a foreign directory.
TEST(SimulatorTest, ForceReplacesOnlyAPreviousDataset) {
    SimConfig c = sim_preset("lab-tiny");
    c.runs = 1;
    c.submaps = 2;
    const fs::path root = temp_root() / "force";
    fs::create_directories(root / "foreign");
    put(root / "foreign" / "notes.txt", "keep");
    put(root / "file", "keep");
    const fs::path previous = root / "previous";
    generate_dataset(c, previous);
    c.seed = 5;
    EXPECT_NO_THROW(generate_dataset(c, previous, true));  // a previous dataset: replaced
    EXPECT_EQ(Dataset::open(previous).manifest().meta.count("sim"), 1u);
    EXPECT_NE(error_of([&] { generate_dataset(c, root / "foreign", true); }).find("not a maptune dataset"),
              std::string::npos);
    EXPECT_TRUE(fs::exists(root / "foreign" / "notes.txt"));
    EXPECT_NE(error_of([&] { generate_dataset(c, root / "file", true); }).find("not a directory"), std::string::npos);
    EXPECT_EQ(read_file(root / "file"), "keep");
    fs::create_directories(root / "empty");
    EXPECT_NO_THROW(generate_dataset(c, root / "empty", true));
    const fs::path cwd = fs::current_path();
    fs::current_path(root / "foreign");
    const std::string here = error_of([&] { generate_dataset(c, ".", true); });
    const std::string parent = error_of([&] { generate_dataset(c, "..", true); });
    fs::current_path(cwd);
    EXPECT_NE(here.find("current directory"), std::string::npos) << here;
    EXPECT_NE(parent.find("current directory"), std::string::npos) << parent;
    EXPECT_TRUE(fs::exists(root / "foreign" / "notes.txt"));
    for (const auto& e : fs::directory_iterator(root))
        EXPECT_EQ(e.path().string().find(".tmp-"), std::string::npos) << "left behind: " << e.path();
}

TEST(SimulatorTest, UnknownPresetIsAnError) {
    EXPECT_NE(error_of([] { sim_preset("mars"); }).find("unknown preset 'mars'"), std::string::npos);
    SimConfig c = sim_preset("lab-tiny");
    c.world = "mars";
    const fs::path out = temp_root() / "mars";
    EXPECT_NE(error_of([&] { generate_dataset(c, out); }).find("unknown world 'mars'"), std::string::npos);
    EXPECT_FALSE(fs::exists(out));
}

std::string d_run0_odometry() { return Dataset::open(lab_tiny()).manifest().runs.at(0).odometry_file; }

TEST(SimulatorTest, SimOptionsSetFieldsAndRejectBadValuesByName) {
    SimConfig c = sim_preset("lab");
    EXPECT_EQ(set_sim_option(c, "world_size", "12"), "");
    EXPECT_DOUBLE_EQ(c.world_size, 12.0);
    EXPECT_EQ(set_sim_option(c, "image_width", "224"), "");
    EXPECT_EQ(c.image_width, 224);
    EXPECT_EQ(set_sim_option(c, "pan_sweep_deg", "-30,0,30"), "");
    EXPECT_EQ(c.pan_sweep_deg, (std::vector<double>{-30, 0, 30}));
    const std::string unknown = set_sim_option(c, "colour", "red");
    EXPECT_NE(unknown.find("colour"), std::string::npos);
    EXPECT_NE(unknown.find("max_range_m"), std::string::npos) << unknown;  // lists the known keys
    EXPECT_NE(set_sim_option(c, "image_width", "10.5").find("integer"), std::string::npos);
    EXPECT_NE(set_sim_option(c, "voxel_m", "-1").find("voxel_m"), std::string::npos);
    EXPECT_NE(set_sim_option(c, "voxel_m", "nan"), "");
    EXPECT_NE(set_sim_option(c, "pan_sweep_deg", "0,x"), "");
    EXPECT_DOUBLE_EQ(c.voxel_m, sim_preset("lab").voxel_m);  // failed sets change nothing
    const auto all = sim_options(c);
    EXPECT_NE(std::find(all.begin(), all.end(), "world_size=12"), all.end());
    EXPECT_NE(std::find(all.begin(), all.end(), "pan_sweep_deg=-30,0,30"), all.end());
}

// Auto exposure changes the colours of a frame, never the geometry.
TEST(SimulatorTest, ExposureChangesColoursButNotGeometry) {
    SimConfig c = sim_preset("lab-tiny");
    c.runs = 1;
    c.submaps = 2;
    const Submap off = second_submap(c, "exposure_off");
    c.exposure_sigma = 0.3;
    const Submap on = second_submap(c, "exposure_on");
    ASSERT_NO_FATAL_FAILURE(expect_same_points(off, on));
    std::size_t same_colour = 0;
    for (std::size_t i = 0; i < off.cloud.size(); ++i) {
        same_colour += off.cloud[i].r == on.cloud[i].r && off.cloud[i].g == on.cloud[i].g ? 1 : 0;
    }
    EXPECT_LT(same_colour, off.cloud.size() / 2);
    EXPECT_EQ(off.obstacles.size(), on.obstacles.size());
}

// Several sites: run 0 stays in the seed's world, run 1 drives the same path noise in another
// world; one world writes no `worlds` setting (datasets made before it keep their ids).
TEST(SimulatorTest, WorldsPutRunsInDifferentWorlds) {
    SimConfig c = sim_preset("lab-tiny");
    c.runs = 2;
    c.submaps = 2;
    generate_dataset(c, temp_root() / "worlds1");
    c.worlds = 2;
    generate_dataset(c, temp_root() / "worlds2");
    const auto one = all_files(temp_root() / "worlds1"), two = all_files(temp_root() / "worlds2");
    for (const std::string f : {"run00/submap000.pcd", "run00/submap001.pcd", "run00/gt.tum"}) {
        EXPECT_EQ(one.at(f), two.at(f)) << f;
    }
    EXPECT_NE(one.at("run01/submap000.pcd"), two.at("run01/submap000.pcd"));
    const auto meta1 = Dataset::open(temp_root() / "worlds1").manifest().meta;
    const auto meta2 = Dataset::open(temp_root() / "worlds2").manifest().meta;
    EXPECT_EQ(meta1.at("sim").find("worlds="), std::string::npos);
    EXPECT_NE(meta2.at("sim").find("worlds=2"), std::string::npos);
    EXPECT_EQ(sim_settings_mismatch(c, meta1), "worlds: the dataset has 1, the settings ask for 2");
    EXPECT_EQ(sim_settings_mismatch(c, meta2), "");
    c.worlds = 3;
    EXPECT_NE(error_of([&] { generate_dataset(c, temp_root() / "worlds3"); }).find("worlds must be in [1, runs]"),
              std::string::npos);
}

// The moon's low sun casts shadows: the same points, some of them darker (only the ambient
// term lights them), none brighter.
TEST(SimulatorTest, CastShadowsDarkenSomePointsAndMoveNone) {
    SimConfig c = sim_preset("moon-tiny");
    c.runs = 1;
    c.submaps = 2;
    c.rocks = 200;  // a rock every 4.5 m²: enough shadowed ground in two small submaps
    const Submap off = second_submap(c, "shadows_off");
    c.cast_shadows = 1;
    const Submap on = second_submap(c, "shadows_on");
    ASSERT_NO_FATAL_FAILURE(expect_same_points(off, on));
    std::size_t darker = 0, brighter = 0;
    for (std::size_t i = 0; i < off.cloud.size(); ++i) {
        darker += on.cloud[i].g + 2 < off.cloud[i].g ? 1 : 0;
        brighter += on.cloud[i].g > off.cloud[i].g + 2 ? 1 : 0;
    }
    EXPECT_GT(darker, off.cloud.size() / 100);
    EXPECT_LT(darker, off.cloud.size() / 2);
    EXPECT_EQ(brighter, 0u);
    EXPECT_EQ(off.obstacles.size(), on.obstacles.size());
}

// Lab appearance settings recolour surfaces without moving them; angular rocks change the
// shape of the rocks only, deterministically.
TEST(SimulatorTest, AppearanceAndRockShapeSettings) {
    SimConfig c = sim_preset("lab-tiny");
    c.runs = 1;
    c.submaps = 2;
    const fs::path base = temp_root() / "appearance_base";
    const Submap a = second_submap(c, "appearance_base");
    SimConfig uniform = c;
    uniform.rock_colour_variation = 0;
    uniform.floor_tile_contrast = 0;
    const Submap u = second_submap(uniform, "appearance_uniform");
    ASSERT_NO_FATAL_FAILURE(expect_same_points(a, u));
    std::size_t same_colour = 0;
    for (std::size_t i = 0; i < a.cloud.size(); ++i) {
        same_colour += a.cloud[i].r == u.cloud[i].r && a.cloud[i].g == u.cloud[i].g ? 1 : 0;
    }
    EXPECT_LT(same_colour, a.cloud.size() / 2);

    SimConfig faceted = c;
    faceted.rock_facets = 8;
    generate_dataset(faceted, temp_root() / "faceted1");
    generate_dataset(faceted, temp_root() / "faceted2");
    const Dataset d0 = Dataset::open(base), d1 = Dataset::open(temp_root() / "faceted1");
    EXPECT_EQ(d1.manifest().id, Dataset::open(temp_root() / "faceted2").manifest().id) << "deterministic";
    EXPECT_NE(d1.manifest().id, d0.manifest().id);
    // The same world and path (rocks keep their places and sizes): the runs start alike.
    const auto& r0 = d0.manifest().runs[0];
    const auto& r1 = d1.manifest().runs[0];
    ASSERT_EQ(r0.gt.size(), r1.gt.size());
    EXPECT_TRUE(r0.gt[0].T.isApprox(r1.gt[0].T, 1e-12));
    EXPECT_EQ(set_sim_option(c, "rock_facets", "2.5").find("integer") != std::string::npos, true);
}

// The lab preset's hall: with the free wander, run 2 of seed 12 turned on the spot between
// rocks for all 15 submaps (origins within 0.3 m); path_unstick lets it squeeze out. The path
// does not depend on the sensor, so a coarse camera keeps the test fast.
TEST(SimulatorTest, ARoverBoxedInBetweenRocksSqueezesOut) {
    auto run2_extent = [](int unstick, const std::string& name) {
        SimConfig c = sim_preset("lab");
        c.seed = 12;
        c.runs = 3;
        c.image_width = 24;
        c.image_height = 18;
        c.voxel_m = 0.15;
        c.octomap_resolution_m = 0.3;
        c.path_unstick = unstick;
        c.threads = 2;
        generate_dataset(c, temp_root() / name);
        const Dataset d = Dataset::open(temp_root() / name);
        double lo_x = 1e9, hi_x = -1e9, lo_y = 1e9, hi_y = -1e9;
        for (const StampedPose& p : d.manifest().runs.at(2).gt) {
            lo_x = std::min(lo_x, p.T.translation().x());
            hi_x = std::max(hi_x, p.T.translation().x());
            lo_y = std::min(lo_y, p.T.translation().y());
            hi_y = std::max(hi_y, p.T.translation().y());
        }
        return std::max(hi_x - lo_x, hi_y - lo_y);
    };
    EXPECT_LT(run2_extent(0, "boxed_in"), 0.5);
    EXPECT_GT(run2_extent(1, "squeezed_out"), 2.0);
}

// Moon rock sizes: the power law puts most rocks near rock_min_m (pebbles), so the same count
// covers far less ground than the old 0.2..1.5 m law; the terrain under the rocks is the same.
TEST(SimulatorTest, PowerLawRocksAreMostlyPebbles) {
    auto rock_cells = [](double exponent) {
        SimConfig c = sim_preset("moon");
        c.world_size = 20;
        c.craters = 0;
        c.rocks = 0;
        const HeightMapImage bare = world_height_map(c, 0.05);
        c.rocks = 400;
        c.rock_size_exponent = exponent;
        c.rock_min_m = 0.1;
        const HeightMapImage rocky = world_height_map(c, 0.05);
        std::size_t n = 0;
        for (std::size_t i = 0; i < bare.height.size(); ++i) n += rocky.height[i] > bare.height[i] + 0.01f ? 1 : 0;
        return static_cast<double>(n) * 0.05 * 0.05;  // m² raised by a rock
    };
    const double old_law = rock_cells(0), power_law = rock_cells(2.5);
    // Old law: mean diameter ~0.6 m, ~0.2 m² each; b = 2.5 from 0.1 m: mean ~0.17 m.
    EXPECT_GT(old_law, 400 * 0.1);
    EXPECT_LT(power_law, 0.25 * old_law);
    EXPECT_GT(power_law, 400 * 0.005);
    SimConfig c;
    EXPECT_NE(set_sim_option(c, "rock_min_m", "0").find("rock_min_m"), std::string::npos);
}

// A manifest describes what a config generates; a setting an older manifest lacks counts as
// its default (the old behaviour), so datasets made before the setting existed still fit.
TEST(SimulatorTest, ManifestSettingsMismatchNamesTheSetting) {
    SimConfig c = sim_preset("lab-tiny");
    std::map<std::string, std::string> meta = Dataset::open(lab_tiny()).manifest().meta;
    EXPECT_EQ(sim_settings_mismatch(c, meta), "");
    c.rocks = 7;
    EXPECT_EQ(sim_settings_mismatch(c, meta), "rocks: the dataset has 0, the settings ask for 7");
    c.seed = 99;
    EXPECT_EQ(sim_settings_mismatch(c, meta), "rocks: the dataset has 0, the settings ask for 7 (and 1 more)");
    c = sim_preset("lab-tiny");
    std::string& sim = meta.at("sim");
    const auto at = sim.find("cast_shadows=0 ");
    ASSERT_NE(at, std::string::npos) << sim;
    sim.erase(at, std::string("cast_shadows=0 ").size());
    EXPECT_EQ(sim_settings_mismatch(c, meta), "");
    c.cast_shadows = 1;
    EXPECT_EQ(sim_settings_mismatch(c, meta), "cast_shadows: the dataset has 0, the settings ask for 1");
}

TEST(SimulatorTest, FailureLeavesNothingThatLooksValid) {
    const fs::path out = temp_root() / "fail";
    {
        DatasetWriter w(out, "x", "test", 0.1, 0.4);
        RunWriter rw = w.run(0);
        Submap s;
        s.cloud.resize(3);
        rw.add_submap(s, 0);
        EXPECT_TRUE(fs::exists(w.temp_dir()));
        // destroyed without finish(): e.g. an exception in the generator
    }
    EXPECT_FALSE(fs::exists(out));
    for (const auto& e : fs::directory_iterator(temp_root())) {
        EXPECT_EQ(e.path().filename().string().find("fail.tmp"), std::string::npos);
    }
    // An existing output is not overwritten silently.
    EXPECT_NE(error_of([&] { generate_dataset(sim_preset("lab-tiny"), lab_tiny()); }).find("already exists"),
              std::string::npos);
}

// m* without ground truth: overlaps under the odometry reference come from the clouds and
// the odometry poses only. Moving one submap's odometry pose far away empties its overlaps
// while the stored gt overlaps stay.
TEST(DatasetTest, ReferenceOverlapsUseOnlyTheChosenPoses) {
    const fs::path copy = temp_root() / "overlap_copy";
    fs::remove_all(copy);
    fs::copy(lab_tiny(), copy, fs::copy_options::recursive);
    {
        const Dataset d = Dataset::open(copy);
        const auto pairs = d.pairs(View::complete, Reference::odometry);
        const auto gt = d.reference_overlaps(pairs, Reference::gt);
        const auto odom = d.reference_overlaps(pairs, Reference::odometry);
        ASSERT_EQ(gt.size(), pairs.size());
        ASSERT_EQ(odom.size(), pairs.size());
        for (std::size_t i = 0; i < pairs.size(); ++i) {
            EXPECT_DOUBLE_EQ(gt[i], pairs[i].overlap);
            EXPECT_GE(odom[i], 0.0);
            EXPECT_LE(odom[i], 1.0);
            // Odometry drifts by centimetres between these submaps: nearly the gt overlap.
            EXPECT_NEAR(odom[i], gt[i], 0.25) << pairs[i].id_a << " " << pairs[i].id_b;
        }
    }
    const fs::path odom_file = copy / d_run0_odometry();
    auto poses = read_tum(odom_file);
    ASSERT_GE(poses.size(), 2u);
    poses[1].T.translation().x() += 500.0;
    std::ofstream(odom_file, std::ios::trunc) << format_tum(poses);
    const Dataset d = Dataset::open(copy);
    const auto pairs = d.pairs(View::complete, Reference::odometry);
    const auto gt = d.reference_overlaps(pairs, Reference::gt);
    const auto odom = d.reference_overlaps(pairs, Reference::odometry);
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        if (pairs[i].run == 0 && (pairs[i].a == 1 || pairs[i].b == 1)) {
            EXPECT_EQ(odom[i], 0.0);
            EXPECT_GT(gt[i], 0.0);
        }
    }
}

TEST(DatasetTest, ViewsAndReferenceTransforms) {
    const Dataset d = Dataset::open(lab_tiny());
    const Manifest& m = d.manifest();
    ASSERT_EQ(m.runs.size(), 2u);
    EXPECT_TRUE(d.verify());
    const auto complete = d.pairs(View::complete, Reference::gt);
    const auto subsequent = d.pairs(View::subsequent, Reference::odometry);
    EXPECT_EQ(complete.size(), 2u * 6u);
    EXPECT_EQ(subsequent.size(), 2u * 3u);
    EXPECT_FALSE(d.locate("run09/submap000").has_value());
    for (const auto& p : complete) {
        const auto& r = m.runs[p.run];
        EXPECT_TRUE(p.T_a_b.isApprox(r.gt[p.a].T.inverse() * r.gt[p.b].T, 1e-12));
        EXPECT_EQ(d.locate(p.id_a), std::make_optional(std::make_pair(p.run, p.a)));
        EXPECT_EQ(d.locate(p.id_b), std::make_optional(std::make_pair(p.run, p.b)));
        EXPECT_GE(p.overlap, 0);
        EXPECT_LE(p.overlap, 1);
    }
    for (const auto& p : subsequent) {
        EXPECT_EQ(p.b, p.a + 1);
        EXPECT_GT(p.overlap, 0.3) << "subsequent submaps must overlap";
        const auto& r = m.runs[p.run];
        EXPECT_TRUE(p.T_a_b.isApprox(r.odometry[p.a].T.inverse() * r.odometry[p.b].T, 1e-12));
    }
}

TEST(DatasetTest, LoadSubmapMatchesManifestAndGroundTruthAligns) {
    const Dataset d = Dataset::open(lab_tiny());
    const Submap a = d.load_submap(0, 0), b = d.load_submap("run00/submap001");
    EXPECT_EQ(a.id, "run00/submap000");
    EXPECT_EQ(a.cloud.size(), d.manifest().runs[0].submaps[0].points);
    EXPECT_EQ(a.obstacles.size(), d.manifest().runs[0].submaps[0].obstacle_points);
    // The content hash of its files (what feature caches key on): stable, and per submap.
    EXPECT_NE(a.content_hash, 0u);
    EXPECT_NE(a.content_hash, b.content_hash);
    EXPECT_EQ(a.content_hash, d.load_submap(0, 0).content_hash);
    ASSERT_TRUE(a.octree);
    // The OctoMap knows free space (in front of the camera) and occupied space (surfaces),
    // and nothing far away.
    std::size_t occupied = 0, free_leaves = 0;
    for (auto it = a.octree->begin_leafs(); it != a.octree->end_leafs(); ++it) {
        (a.octree->isNodeOccupied(*it) ? occupied : free_leaves)++;
    }
    EXPECT_GT(occupied, 100u);
    EXPECT_GT(free_leaves, 100u);
    EXPECT_EQ(a.octree->search(100.0, 100.0, 100.0), nullptr);
    // The .bt file is a standard OctoMap file (octomap's own reader accepts it).
    octomap::OcTree standard(0.1);
    ASSERT_TRUE(standard.readBinary((lab_tiny() / "run00/submap000.bt").string()));
    EXPECT_EQ(standard.size(), a.octree->size());
    EXPECT_DOUBLE_EQ(standard.getResolution(), a.octree->getResolution());
    // With gt poses, b's points land on a's surfaces: most voxels coincide.
    const auto ka = world_voxel_keys(a.cloud, a.T_world_submap_gt, 0.25f);
    const auto kb = world_voxel_keys(b.cloud, b.T_world_submap_gt, 0.25f);
    EXPECT_GT(overlap_ratio(ka, kb), 0.4);
    EXPECT_FALSE(a.T_world_submap_gt.isApprox(a.T_world_submap_odom, 1e-9) &&
                 b.T_world_submap_gt.isApprox(b.T_world_submap_odom, 1e-9));
}

TEST(DatasetTest, StatsAndOdometryErrorBelowTenCentimetres) {
    const Dataset d = Dataset::open(lab_tiny());
    const DatasetStats s = compute_stats(d);
    EXPECT_EQ(s.runs, 2u);
    EXPECT_EQ(s.submaps, 8u);
    EXPECT_EQ(s.complete_pairs, 12u);
    EXPECT_GT(s.points_per_submap.mean, 500);
    EXPECT_GT(s.obstacles_per_submap.mean, 10);
    EXPECT_GT(s.submap_size.mean, 1);
    EXPECT_EQ(s.odom_translation_error.n, 6u);
    EXPECT_GT(s.odom_translation_error.mean, 0);  // odometry drifts
    EXPECT_LT(s.odom_translation_error.std, 0.10);
    EXPECT_NE(format_stats(d, s).find("odometry error subsequent"), std::string::npos);
}

TEST(DatasetTest, BadDatasetFilesAreNamed) {
    const fs::path dir = temp_root() / "broken";
    fs::copy(lab_tiny(), dir, fs::copy_options::recursive);
    EXPECT_NE(error_of([&] { Dataset::open(temp_root() / "nope"); }).find("nope"), std::string::npos);
    // Pose count mismatch.
    const std::string gt = read_file(dir / "run01/gt.tum");
    put(dir / "run01/gt.tum", gt.substr(0, gt.rfind('\n', gt.size() - 2) + 1));
    EXPECT_NE(error_of([&] { Dataset::open(dir); }).find("run01/gt.tum: 3 poses for 4 submaps"), std::string::npos);
    put(dir / "run01/gt.tum", gt);
    // Truncated cloud and OctoMap.
    const Dataset d = Dataset::open(dir);
    EXPECT_FALSE(d.verify() == false);
    const std::string pcd = read_file(dir / "run00/submap001.pcd");
    put(dir / "run00/submap001.pcd", pcd.substr(0, pcd.size() / 2));
    EXPECT_NE(error_of([&] { d.load_submap(0, 1); }).find("run00/submap001.pcd: truncated"), std::string::npos);
    EXPECT_FALSE(d.verify());
    const std::string bt = read_file(dir / "run00/submap002.bt");
    put(dir / "run00/submap002.bt", bt.substr(0, bt.size() / 3));
    EXPECT_NE(error_of([&] { d.load_submap(0, 2); }).find("submap002.bt"), std::string::npos);
    fs::remove(dir / "run00/submap003_obstacles.pcd");
    EXPECT_NE(error_of([&] { d.load_submap(0, 3); }).find("submap003_obstacles.pcd: cannot open"), std::string::npos);
    // Issue 14: values that were accepted silently.
    const std::string manifest = read_file(dir / "manifest.yaml");
    auto with = [&](const std::string& from, const std::string& to) {
        std::string m = manifest;
        const auto at = m.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        if (at != std::string::npos) m.replace(at, from.size(), to);
        put(dir / "manifest.yaml", m);
    };
    const std::string voxel = manifest.substr(manifest.find("voxel_size:"), manifest.find('\n', manifest.find("voxel_size:")) -
                                                                               manifest.find("voxel_size:"));
    with(voxel, "voxel_size: -0.04");
    EXPECT_NE(error_of([&] { Dataset::open(dir); }).find("voxel_size: -0.04"), std::string::npos);
    with(voxel, "voxel_size: .nan");
    EXPECT_NE(error_of([&] { Dataset::open(dir); }).find("is not a positive number"), std::string::npos);
    put(dir / "manifest.yaml", manifest);
    const std::string pairs_file = Dataset::open(dir).manifest().runs.at(0).pairs_file;
    const std::string pairs = read_file(dir / pairs_file);
    put(dir / pairs_file, pairs + "0 3 1.5\n");
    EXPECT_NE(error_of([&] { Dataset::open(dir); }).find("overlap in [0, 1]"), std::string::npos);
    put(dir / pairs_file, pairs);
    // A cloud with a coordinate of 3e38 (finite, but no robot's): refused like NaN.
    put(dir / "run00/submap001.pcd", "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\n"
                                    "HEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3\n3e38 0 0\n");
    EXPECT_NE(error_of([&] { d.load_submap(0, 1); }).find("1 points with a coordinate beyond"), std::string::npos);
    fs::remove(dir / "manifest.yaml");
    EXPECT_NE(error_of([&] { Dataset::open(dir); }).find("missing manifest"), std::string::npos);
}

// Issue 14: a file changed after the dataset was written — still a valid cloud — is refused
// when loaded, so its results never enter the store under the dataset's old id.
TEST(DatasetTest, AFileChangedInPlaceIsRefusedWhenLoaded) {
    const fs::path dir = temp_root() / "changed";
    fs::copy(lab_tiny(), dir, fs::copy_options::recursive);
    const Dataset d = Dataset::open(dir);
    EXPECT_FALSE(d.manifest().file_hashes.empty());
    EXPECT_NO_THROW(d.load_submap(0, 1));
    std::string obstacles = read_file(dir / "run00/submap001_obstacles.pcd");
    obstacles[obstacles.size() - 2] ^= 0x01;  // one bit of the last coordinate
    put(dir / "run00/submap001_obstacles.pcd", obstacles);
    EXPECT_NE(error_of([&] { d.load_submap(0, 1); })
                  .find("run00/submap001_obstacles.pcd: changed since the dataset was written"),
              std::string::npos);
    EXPECT_NO_THROW(d.load_submap(0, 2));
    EXPECT_FALSE(d.verify());
}

TEST(SimulatorTest, MoonTinyHasTerrainObstacles) {
    const fs::path out = temp_root() / "moon_tiny";
    generate_dataset(sim_preset("moon-tiny"), out);
    const Dataset d = Dataset::open(out);
    const DatasetStats s = compute_stats(d);
    EXPECT_EQ(s.submaps, 8u);
    EXPECT_GT(s.obstacles_per_submap.mean, 5);
    EXPECT_LT(s.obstacles_per_submap.mean, 0.5 * s.points_per_submap.mean);  // few features
    EXPECT_GT(s.subsequent_overlap.min, 0.2);
}

TEST(ImportTest, CloudsAndTumPosesToDataset) {
    const Dataset src = Dataset::open(lab_tiny());
    const fs::path in = temp_root() / "import_in";
    fs::create_directories(in);
    std::vector<StampedPose> poses;
    ImportInput input;
    for (int i = 0; i < 3; ++i) {
        const Submap s = src.load_submap(0, i);
        put(in / ("c" + std::to_string(i) + ".pcd"), format_pcd_xyzrgb(s.cloud));
        input.clouds.push_back(in / ("c" + std::to_string(i) + ".pcd"));
        poses.push_back({double(i), s.T_world_submap_gt});
    }
    put(in / "poses.tum", format_tum(poses));
    put(in / "short.tum", format_tum({poses[0], poses[1]}));
    EXPECT_NE(error_of([&] { read_poses_for(in / "short.tum", 3); }).find("short.tum: has 2 poses but 3 clouds"),
              std::string::npos);
    input.poses = read_poses_for(in / "poses.tum", 3);
    ImportOptions o;
    o.voxel_m = 0.06;
    o.obstacle_method = "height";
    o.sensor_origin = Eigen::Vector3f(0, 0, 1);
    const fs::path out = temp_root() / "imported";
    import_dataset(input, o, out);
    const Dataset d = Dataset::open(out);
    EXPECT_TRUE(d.verify());
    EXPECT_EQ(d.num_submaps(), 3u);
    EXPECT_EQ(d.manifest().meta.at("obstacles"), "derived:height");
    const Submap s = d.load_submap(0, 1);
    EXPECT_TRUE(s.T_world_submap_gt.isApprox(poses[1].T, 1e-6));
    EXPECT_TRUE(s.octree);
    EXPECT_FALSE(s.obstacles.empty());
    // A NaN point is rejected with the file's name; a missing file too; nothing is written.
    auto cloud = src.load_submap(0, 0).cloud;
    cloud[7].x = std::nanf("");
    put(in / "c1.pcd", format_pcd_xyzrgb(cloud));
    const fs::path out2 = temp_root() / "imported_bad";
    EXPECT_NE(error_of([&] { import_dataset(input, o, out2); }).find("c1.pcd: 1 points with NaN"), std::string::npos);
    EXPECT_FALSE(fs::exists(out2));
    input.clouds[2] = in / "gone.ply";
    EXPECT_NE(error_of([&] { import_dataset(input, o, out2); }).find("gone.ply: missing"), std::string::npos);
    // Issue 14: an interrupted import (SIGINT in `dataset import`) leaves neither the dataset
    // nor its temporary directory.
    put(in / "c1.pcd", format_pcd_xyzrgb(src.load_submap(0, 1).cloud));
    input.clouds[2] = in / "c2.pcd";
    int asked = 0;
    o.interrupted = [&] { return ++asked > 1; };
    EXPECT_NE(error_of([&] { import_dataset(input, o, out2); }).find("interrupted: nothing written"), std::string::npos);
    EXPECT_EQ(asked, 2) << "asked before each cloud, stopped before the second";
    for (const auto& entry : fs::directory_iterator(temp_root())) {
        EXPECT_EQ(entry.path().filename().string().find("imported_bad"), std::string::npos) << entry.path();
    }
}

TEST(ImportTest, StanfordBunnyRealScans) {
    const fs::path dir = fs::path(MAPTUNE_SOURCE_DIR) / "tests/data/stanford_bunny";  // in the repository
    ImportInput input = read_bunny_conf(dir / "bun.conf");
    ASSERT_EQ(input.clouds.size(), 10u);
    // Three scans keep the test fast: bun000, bun045, bun090.
    input.clouds.resize(3);
    input.poses.resize(3);
    const fs::path out = temp_root() / "bunny";
    import_dataset(input, bunny_options(), out);
    const Dataset d = Dataset::open(out);
    const auto pairs = d.pairs(View::complete, Reference::gt);
    ASSERT_EQ(pairs.size(), 3u);
    // With the README's convention the scans align to sub-millimetre: median nearest-
    // neighbour distance from bun045 moved into bun000's frame.
    const Submap a = d.load_submap(0, 0), b = d.load_submap(0, 1);
    const Eigen::Isometry3f T = pairs[0].T_a_b.cast<float>();
    std::vector<float> dists;
    for (std::size_t i = 0; i < b.cloud.size(); i += 7) {
        const Eigen::Vector3f p = T * Eigen::Vector3f(b.cloud[i].x, b.cloud[i].y, b.cloud[i].z);
        float best = 1e9f;
        for (const auto& q : a.cloud) best = std::min(best, (p - Eigen::Vector3f(q.x, q.y, q.z)).squaredNorm());
        dists.push_back(std::sqrt(best));
    }
    std::nth_element(dists.begin(), dists.begin() + dists.size() / 2, dists.end());
    EXPECT_LT(dists[dists.size() / 2], 0.0015f);  // voxel 2 mm
    EXPECT_GT(pairs[0].overlap, 0.5);
    EXPECT_GT(a.obstacles.size(), 10u);
    EXPECT_LT(a.obstacles.size(), a.cloud.size() / 2);
}

TEST(RenderTest, WritesPng) {
    const Dataset d = Dataset::open(lab_tiny());
    const fs::path png = temp_root() / "run.png";
    write_png(png, render_run_topdown(d, 0, 300));
    const std::string bytes = read_file(png);
    EXPECT_EQ(bytes.substr(1, 3), "PNG");
    write_png(temp_root() / "sub.png", render_submap(d.load_submap(0, 0), 320, 240));
    EXPECT_GT(fs::file_size(temp_root() / "sub.png"), 1000u);
}

// Multi-fidelity subsets (issue 16 item 2): about 1/k of the pairs, every run in proportion,
// few submaps (features) per pair, the whole length of the runs, always the same pairs.
namespace {

std::vector<SubmapPair> synthetic_pairs(int runs, int submaps, View view) {
    std::vector<SubmapPair> out;
    for (int r = 0; r < runs; ++r) {
        for (int a = 0; a < submaps; ++a) {
            for (int b = a + 1; b < submaps; ++b) {
                if (view == View::subsequent && b != a + 1) continue;
                SubmapPair p;
                p.run = r;
                p.a = a;
                p.b = b;
                p.id_a = "run" + std::to_string(r) + "/submap" + std::to_string(a);
                p.id_b = "run" + std::to_string(r) + "/submap" + std::to_string(b);
                out.push_back(p);
            }
        }
    }
    return out;
}

std::size_t touched_submaps(const std::vector<SubmapPair>& pairs) {
    std::set<std::string> ids;
    for (const auto& p : pairs) ids.insert({p.id_a, p.id_b});
    return ids.size();
}

}  // namespace

TEST(ViewSpec, ParsesSubsetsAndRejectsWhatIsNotOne) {
    EXPECT_EQ(parse_view_spec("subsequent").subset, 1);
    const auto s = parse_view_spec("complete/8");
    EXPECT_EQ(s.view, View::complete);
    EXPECT_EQ(s.subset, 8);
    EXPECT_EQ(s.str(), "complete/8");
    EXPECT_EQ(parse_view_spec("subsequent").str(), "subsequent");
    for (const char* bad : {"subsequent/1", "subsequent/0", "subsequent/", "subsequent/x", "subsequent/8x",
                            "sideways/8", "subsequent/-4", "complete/99999999"}) {
        EXPECT_THROW(parse_view_spec(bad), std::invalid_argument) << bad;
    }
}

TEST(StratifiedSubset, SubsequentViewTakesContiguousStretchesFromEveryRun) {
    const auto all = synthetic_pairs(40, 40, View::subsequent);  // the moon preset's shape
    for (const int k : {2, 4, 8, 16}) {
        const auto sub = stratified_subset(all, View::subsequent, k);
        const std::size_t target = (all.size() + k - 1) / k;
        EXPECT_GE(sub.size(), target) << k;
        EXPECT_LE(sub.size(), target + 1) << k;
        std::map<int, int> per_run;
        for (const auto& p : sub) ++per_run[p.run];
        EXPECT_EQ(per_run.size(), 40u) << "every run is represented, k = " << k;
        for (const auto& [run, n] : per_run) {
            EXPECT_NEAR(n, 39.0 / k, 1.0) << "run " << run << " in proportion, k = " << k;
        }
        // Contiguous: n pairs of a run need n + 1 submaps.
        EXPECT_EQ(touched_submaps(sub), sub.size() + per_run.size()) << k;
        EXPECT_EQ(stratified_subset(all, View::subsequent, k).size(), sub.size());
    }
    // The stretches start at different places along the runs: early, middle and late pairs.
    const auto sub = stratified_subset(all, View::subsequent, 8);
    std::set<int> thirds;
    for (const auto& p : sub) thirds.insert(p.a * 3 / 40);
    EXPECT_EQ(thirds.size(), 3u);
}

TEST(StratifiedSubset, CompleteViewSpreadsItsSubmapsSoNearAndFarPairsAppear) {
    const auto all = synthetic_pairs(40, 40, View::complete);  // 31 200 pairs
    const auto sub = stratified_subset(all, View::complete, 8);
    const std::size_t target = all.size() / 8;
    EXPECT_GE(sub.size(), target);
    EXPECT_LE(sub.size(), target + 40u);
    // Pairs grow with the square of the submaps: 1/8 of the pairs needs far fewer than 1/2 of the features.
    EXPECT_LE(touched_submaps(sub), 1600u * 45 / 100);
    int max_gap = 0, min_gap = 40;
    std::map<int, int> per_run;
    for (const auto& p : sub) {
        max_gap = std::max(max_gap, p.b - p.a);
        min_gap = std::min(min_gap, p.b - p.a);
        ++per_run[p.run];
    }
    EXPECT_EQ(per_run.size(), 40u);
    EXPECT_EQ(min_gap, 1);
    EXPECT_GE(max_gap, 30);
}

TEST(StratifiedSubset, SmallViewsKeepAtLeastOnePairAndKOneIsTheView) {
    const auto all = synthetic_pairs(1, 3, View::subsequent);
    EXPECT_EQ(stratified_subset(all, View::subsequent, 1).size(), all.size());
    EXPECT_EQ(stratified_subset(all, View::subsequent, 100).size(), 1u);
    EXPECT_TRUE(stratified_subset({}, View::subsequent, 8).empty());
}
