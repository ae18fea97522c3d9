// File formats: TUM, PCD, PLY readers and writers, and their error messages.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <fstream>
#include <random>
#include <thread>

#include "dataset/geometry.hpp"
#include "dataset/io.hpp"

namespace fs = std::filesystem;
using namespace maptune::dataset;

namespace {

class TempDir : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("maptune_io_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    void put(const fs::path& p, const std::string& s) { std::ofstream(p, std::ios::binary) << s; }
    fs::path dir_;
};

template <typename F>
std::string error_of(F&& f) {
    try {
        f();
    } catch (const DatasetError& e) {
        return e.what();
    }
    return "";
}

std::vector<ColoredPoint> random_cloud(int n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-5, 5);
    std::vector<ColoredPoint> c(n);
    for (auto& p : c) {
        p.x = u(rng); p.y = u(rng); p.z = u(rng);
        p.r = static_cast<std::uint8_t>(rng()); p.g = static_cast<std::uint8_t>(rng()); p.b = static_cast<std::uint8_t>(rng());
    }
    return c;
}

}  // namespace

using IoTest = TempDir;

TEST_F(IoTest, TumRoundTripAndCanonicalQuaternion) {
    std::vector<StampedPose> poses(3);
    for (int i = 0; i < 3; ++i) {
        poses[i].timestamp = i * 0.5;
        poses[i].T.linear() = Eigen::AngleAxisd(0.3 * i + 3.0, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
        poses[i].T.translation() = Eigen::Vector3d(i, -i, 0.1 * i);
    }
    put(dir_ / "a.tum", format_tum(poses));
    const auto back = read_tum(dir_ / "a.tum");
    ASSERT_EQ(back.size(), 3u);
    for (int i = 0; i < 3; ++i) {
        EXPECT_TRUE(back[i].T.isApprox(poses[i].T, 1e-6));
        EXPECT_DOUBLE_EQ(back[i].timestamp, poses[i].timestamp);
    }
    EXPECT_EQ(format_tum(back), format_tum(poses));  // stable text
}

TEST_F(IoTest, TumErrorsNameFileAndLine) {
    put(dir_ / "bad.tum", "# c\n0 1 2 3 0 0 0 1\n1 1 2 3 0 0\n");
    EXPECT_NE(error_of([&] { read_tum(dir_ / "bad.tum"); }).find("bad.tum: line 3"), std::string::npos);
    put(dir_ / "q.tum", "0 1 2 3 0 0 0 2\n");
    EXPECT_NE(error_of([&] { read_tum(dir_ / "q.tum"); }).find("not unit length"), std::string::npos);
    EXPECT_NE(error_of([&] { read_tum(dir_ / "missing.tum"); }).find("missing.tum: cannot open"), std::string::npos);
}

TEST_F(IoTest, PcdBinaryRoundTripIsExact) {
    const auto cloud = random_cloud(500, 1);
    put(dir_ / "c.pcd", format_pcd_xyzrgb(cloud));
    const auto back = read_cloud(dir_ / "c.pcd");
    ASSERT_EQ(back.size(), cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        EXPECT_EQ(back[i].x, cloud[i].x);
        EXPECT_EQ(back[i].z, cloud[i].z);
        EXPECT_EQ(back[i].r, cloud[i].r);
        EXPECT_EQ(back[i].g, cloud[i].g);
        EXPECT_EQ(back[i].b, cloud[i].b);
    }
    std::vector<Eigen::Vector3f> pts = {{1, 2, 3}, {4, 5, 6}};
    put(dir_ / "o.pcd", format_pcd_xyz(pts));
    EXPECT_EQ(read_points(dir_ / "o.pcd"), pts);
    put(dir_ / "e.pcd", format_pcd_xyz({}));
    EXPECT_TRUE(read_points(dir_ / "e.pcd").empty());  // no obstacles is legitimate
}

TEST_F(IoTest, PcdBadInput) {
    const std::string full = format_pcd_xyzrgb(random_cloud(100, 2));
    put(dir_ / "t.pcd", full.substr(0, full.size() - 40));
    const std::string e = error_of([&] { read_cloud(dir_ / "t.pcd"); });
    EXPECT_NE(e.find("t.pcd: truncated"), std::string::npos) << e;
    auto nan_cloud = random_cloud(10, 3);
    nan_cloud[4].y = std::nanf("");
    put(dir_ / "n.pcd", format_pcd_xyzrgb(nan_cloud));
    EXPECT_NE(error_of([&] { read_cloud(dir_ / "n.pcd"); }).find("n.pcd: 1 points with NaN"), std::string::npos);
    ReadOptions drop;
    drop.drop_nan = true;
    EXPECT_EQ(read_cloud(dir_ / "n.pcd", drop).size(), 9u);
    put(dir_ / "z.pcd", format_pcd_xyzrgb({}));
    EXPECT_NE(error_of([&] { read_cloud(dir_ / "z.pcd"); }).find("z.pcd: empty cloud"), std::string::npos);
    put(dir_ / "x.xyz", "1 2 3\n");
    EXPECT_NE(error_of([&] { read_cloud(dir_ / "x.xyz"); }).find("unknown cloud format"), std::string::npos);
}

// Issue 14: hostile headers segfaulted (negative or huge COUNT/SIZE: offsets beyond the record)
// or were read as zeros; each is now an error naming the file and what is wrong.
TEST_F(IoTest, PcdHostileHeadersAreErrors) {
    const std::string head = "VERSION .7\nFIELDS x y z\n";
    const std::string tail = "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary\n" + std::string(24, '\0');
    struct Case {
        std::string header, fragment;
    };
    for (const Case& c : std::vector<Case>{
             {"SIZE 4 4 -4\nTYPE F F F\nCOUNT 1 1 1\n", "SIZE -4 is not 1, 2, 4 or 8"},
             {"SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 -3\n", "COUNT -3 is not in 1..100000"},
             {"SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 0\n", "COUNT 0"},
             {"SIZE 4 4 4\nTYPE F F F\nCOUNT 1 2000000000 1\n", "COUNT 2000000000"},
             {"SIZE 4 4 1073741824\nTYPE F F F\nCOUNT 1 1 1\n", "SIZE 1073741824"},
             {"SIZE 4 4 4\nTYPE F F Q\nCOUNT 1 1 1\n", "TYPE Q"},
             {"SIZE 4 4 2\nTYPE F F F\nCOUNT 1 1 1\n", "a float of SIZE 2"},
             {"SIZE 4 4 4\nTYPE F U F\nCOUNT 1 1 1\n", "TYPE U: coordinates must be floats"},
             {"SIZE 4 4 4\nTYPE I F F\nCOUNT 1 1 1\n", "TYPE I: coordinates must be floats"},
         }) {
        put(dir_ / "h.pcd", head + c.header + tail);
        const std::string e = error_of([&] { read_cloud(dir_ / "h.pcd"); });
        EXPECT_NE(e.find("h.pcd: PCD field"), std::string::npos) << c.header << " → " << e;
        EXPECT_NE(e.find(c.fragment), std::string::npos) << c.header << " → " << e;
    }
    put(dir_ / "p.pcd", head + "SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nPOINTS -5\nDATA ascii\n1 2 3\n");
    EXPECT_NE(error_of([&] { read_cloud(dir_ / "p.pcd"); }).find("points in a file of"), std::string::npos);
    put(dir_ / "w.pcd", head + "SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nPOINTS 1\nDATA ascii\n1 two 3\n");
    EXPECT_NE(error_of([&] { read_cloud(dir_ / "w.pcd"); }).find("'two' is not a number"), std::string::npos);
}

// Issue 14: a binary element without properties but with a huge count looped for ever.
TEST_F(IoTest, PlyHostileHeadersAreErrors) {
    const std::string vertex = "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n";
    std::string xyz;
    for (float v : {1.f, 2.f, 3.f}) xyz.append(reinterpret_cast<const char*>(&v), 4);
    put(dir_ / "e.ply", "ply\nformat binary_little_endian 1.0\nelement junk 18446744073709551615\n" + vertex +
                            "end_header\n" + xyz);
    EXPECT_NE(error_of([&] { read_cloud(dir_ / "e.ply"); }).find("'junk' announces"), std::string::npos);
    put(dir_ / "f.ply", "ply\nformat binary_little_endian 1.0\nelement junk 5\n" + vertex + "end_header\n" + xyz);
    EXPECT_NE(error_of([&] { read_cloud(dir_ / "f.ply"); }).find("has entries but no properties"), std::string::npos);
    put(dir_ / "g.ply", "ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list uchar int32 idx\n" +
                            vertex + "end_header\n\xff" + xyz);
    const std::string g = error_of([&] { read_cloud(dir_ / "g.ply"); });
    EXPECT_NE(g.find("truncated binary PLY data"), std::string::npos) << g;
    put(dir_ / "t.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                            "property quaternion z\nend_header\n" + xyz);
    EXPECT_NE(error_of([&] { read_cloud(dir_ / "t.ply"); }).find("unknown type 'quaternion'"), std::string::npos);
}

// Issue 14: writing onto a directory left its temporary `.part-*` file behind.
TEST_F(IoTest, AFailedWriteLeavesNoTemporaryFile) {
    fs::create_directories(dir_ / "target");
    const std::string e = error_of([&] { write_file(dir_ / "target", "bytes"); });
    EXPECT_NE(e.find("target: cannot write"), std::string::npos) << e;
    for (const auto& entry : fs::directory_iterator(dir_))
        EXPECT_EQ(entry.path().filename().string().find(".part"), std::string::npos) << entry.path();
}

TEST_F(IoTest, PcdAsciiWithRgbAndExtraFields) {
    float rgb_f;
    const std::uint32_t rgb = (10u << 16) | (20u << 8) | 30u;
    std::memcpy(&rgb_f, &rgb, 4);
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.10g", rgb_f);
    put(dir_ / "a.pcd", std::string("VERSION .7\nFIELDS x y z intensity rgb\nSIZE 4 4 4 4 4\nTYPE F F F F F\n"
                                    "COUNT 1 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3 9 ") +
                            buf + "\n4 5 6 9 " + buf + "\n");
    const auto c = read_cloud(dir_ / "a.pcd");
    ASSERT_EQ(c.size(), 2u);
    EXPECT_EQ(c[1].x, 4);
    EXPECT_EQ(c[1].r, 10);
    EXPECT_EQ(c[1].g, 20);
    EXPECT_EQ(c[1].b, 30);
}

TEST_F(IoTest, PlyAsciiAndBinary) {
    put(dir_ / "a.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                        "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
                        "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                        "1 2 3 255 0 7\n4 5 6 1 2 3\n3 0 1 1\n");
    auto c = read_cloud(dir_ / "a.ply");
    ASSERT_EQ(c.size(), 2u);
    EXPECT_EQ(c[0].r, 255);
    EXPECT_EQ(c[0].b, 7);
    EXPECT_EQ(c[1].z, 6);
    std::string bin = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nend_header\n";
    for (float v : {1.f, 2.f, 3.f, 4.f, 5.f, 6.f, 7.f, 8.f, 9.f}) bin.append(reinterpret_cast<const char*>(&v), 4);
    put(dir_ / "b.ply", bin);
    c = read_cloud(dir_ / "b.ply");
    ASSERT_EQ(c.size(), 3u);
    EXPECT_EQ(c[2].y, 8);
    EXPECT_EQ(c[2].r, 128);  // no colour: grey
    put(dir_ / "t.ply", bin.substr(0, bin.size() - 5));
    EXPECT_NE(error_of([&] { read_cloud(dir_ / "t.ply"); }).find("t.ply: truncated"), std::string::npos);
    put(dir_ / "u.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                        "property float z\nend_header\n1 2 3\n");
    EXPECT_NE(error_of([&] { read_cloud(dir_ / "u.ply"); }).find("u.ply: truncated"), std::string::npos);
}

// Issue 14: a crafted chain of single-child inner nodes overflowed the stack inside OctoMap's
// recursive reader; a real tree still round-trips.
TEST(GeometryTest, OctreeReaderRefusesTreesDeeperThanOctoMapAllows) {
    octomap::OcTree tree(0.05);
    for (int i = 0; i < 50; ++i) tree.updateNode(octomap::point3d(0.1f * i, 0.02f * i, 0.3f), i % 3 != 0);
    const auto back = octree_from_bt(octree_to_bt(tree), "ok.bt");
    EXPECT_EQ(back->size(), tree.size());
    const std::string header = "# Octomap OcTree binary file\nid OcTree\nsize 100001\nres 0.05\ndata\n";
    std::string chain;
    for (int i = 0; i < 100000; ++i) chain += std::string("\x03\x00", 2);  // first child: inner
    chain += std::string("\x01\x00", 2);  // ... down to one occupied leaf
    const std::string e = error_of([&] { octree_from_bt(header + chain, "deep.bt"); });
    EXPECT_NE(e.find("deep.bt: OctoMap data deeper than 16 levels"), std::string::npos) << e;
    const std::string cut = error_of([&] { octree_from_bt(header + std::string("\x03\x00\x03", 3), "cut.bt"); });
    EXPECT_NE(cut.find("cut.bt: truncated OctoMap data"), std::string::npos) << cut;
}

TEST(GeometryTest, VoxelFilterAveragesAndIsOrderIndependent) {
    auto cloud = random_cloud(5000, 4);
    const auto a = voxel_filter(cloud, 1.0f);
    std::reverse(cloud.begin(), cloud.end());
    const auto b = voxel_filter(cloud, 1.0f);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_LE(a.size(), 1000u);
    for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_NEAR(a[i].x, b[i].x, 1e-5);
        EXPECT_EQ(voxel_key({a[i].x, a[i].y, a[i].z}, 1.0f), voxel_key({b[i].x, b[i].y, b[i].z}, 1.0f));
    }
}

TEST(GeometryTest, OverlapRatio) {
    const std::vector<std::uint64_t> a = {1, 2, 3, 4}, b = {3, 4, 5, 6, 7, 8};
    EXPECT_DOUBLE_EQ(overlap_ratio(a, b), 0.5);
    EXPECT_DOUBLE_EQ(overlap_ratio(a, a), 1.0);
    EXPECT_DOUBLE_EQ(overlap_ratio(a, {}), 0.0);
}

namespace {
std::vector<ColoredPoint> grid_points(float x0, float x1, float y0, float y1, float step,
                                      const std::function<float(float, float)>& z) {
    std::vector<ColoredPoint> c;
    for (float x = x0; x < x1; x += step)
        for (float y = y0; y < y1; y += step) {
            ColoredPoint p;
            p.x = x; p.y = y; p.z = z(x, y);
            c.push_back(p);
        }
    return c;
}
}  // namespace

TEST(GeometryTest, HeightObstaclesFindStepsNotFloor) {
    // Flat floor with a 0.3 m box at x in [1, 1.5].
    auto c = grid_points(-2, 3, -1, 1, 0.04f, [](float x, float) { return (x >= 1 && x < 1.5f) ? 0.3f : 0.f; });
    const auto obs = detect_obstacles_height(c);
    ASSERT_FALSE(obs.empty());
    for (const auto& o : obs) {
        EXPECT_GT(o.z(), 0.2f);  // the box top edge, never the floor
        EXPECT_GT(o.x(), 0.85f);
        EXPECT_LT(o.x(), 1.65f);
    }
    // No obstacles on a gentle 10 degree ramp.
    auto ramp = grid_points(-2, 2, -2, 2, 0.04f, [](float x, float) { return 0.176f * x; });
    EXPECT_TRUE(detect_obstacles_height(ramp).empty());
}

TEST(GeometryTest, HeightObstaclesTopSurfaceKeepsTheHighestPointPerColumn) {
    // Floor plus a vertical wall face at x = 1 (points every 4 cm up to 1 m): every wall
    // point is an obstacle, but a grid-map detector sees one column per cell.
    auto c = grid_points(-1, 1, -1, 1, 0.04f, [](float, float) { return 0.f; });
    for (float z = 0.04f; z < 1.0f; z += 0.04f)
        for (float y = -1; y < 1; y += 0.04f) {
            ColoredPoint p;
            p.x = 1.0f; p.y = y; p.z = z;
            c.push_back(p);
        }
    HeightObstacleSettings s;
    s.max_height = 0.6f;
    const auto all = detect_obstacles_height(c, s);
    s.top_surface_cell = 0.04f;
    const auto tops = detect_obstacles_height(c, s);
    ASSERT_FALSE(tops.empty());
    EXPECT_GT(all.size(), 10 * tops.size());
    // One point per 4 cm column along the wall (50 in y), each the highest below max_height.
    EXPECT_NEAR(static_cast<double>(tops.size()), 50.0, 2.0);
    for (const auto& o : tops) {
        EXPECT_NEAR(o.x(), 1.0f, 1e-4f);
        EXPECT_GT(o.z(), 0.5f);
        EXPECT_LE(o.z(), 0.6f + 1e-4f);
    }
}

TEST(GeometryTest, HeightObstaclesFindNegativeEdge) {
    // Ground at 0 for x < 0, a hole (no data) for 0..0.3, then ground at -0.5 (a drop-off).
    auto c = grid_points(-1, 1.5f, -1, 1, 0.04f, [](float x, float) { return x < 0 ? 0.f : -0.5f; });
    c.erase(std::remove_if(c.begin(), c.end(), [](const ColoredPoint& p) { return p.x >= 0 && p.x < 0.3f; }),
            c.end());
    const auto obs = detect_obstacles_height(c);
    ASSERT_FALSE(obs.empty());
    for (const auto& o : obs) {
        EXPECT_GT(o.x(), -0.25f);
        EXPECT_LT(o.x(), 0.0f);
    }
}

TEST(GeometryTest, CurvatureObstaclesOnEdgesOnly) {
    // Two planes meeting at a right angle along x = 0.
    auto c = grid_points(-1, 0, -1, 1, 0.02f, [](float, float) { return 0.f; });
    for (float z = 0.02f; z < 1; z += 0.02f)
        for (float y = -1; y < 1; y += 0.02f) {
            ColoredPoint p;
            p.x = 0; p.y = y; p.z = z;
            c.push_back(p);
        }
    CurvatureObstacleSettings s;
    s.radius = 0.08f;
    const auto obs = detect_obstacles_curvature(c, s);
    ASSERT_FALSE(obs.empty());
    for (const auto& o : obs) EXPECT_LT(std::abs(o.x()) + std::abs(o.z()), 0.2f);
}

namespace maptune::dataset {

// Two writers of one file (workers sharing a cache directory): the file is always one
// writer's complete content, and no temporary file is left behind.
TEST_F(IoTest, ConcurrentWritersOfOneFileNeverMixTheirBytes) {
    const fs::path file = dir_ / "cloud.bin";
    const std::string a(1 << 20, 'a'), b(1 << 20, 'b');
    for (int round = 0; round < 20; ++round) {
        std::thread ta([&] { write_file(file, a); });
        std::thread tb([&] { write_file(file, b); });
        ta.join();
        tb.join();
        const std::string got = read_file(file);
        ASSERT_TRUE(got == a || got == b) << "round " << round << ": mixed content";
    }
    int left = 0;
    for (const auto& e : fs::directory_iterator(dir_)) left += e.path().filename() != "cloud.bin";
    EXPECT_EQ(left, 0);
}

}  // namespace maptune::dataset
