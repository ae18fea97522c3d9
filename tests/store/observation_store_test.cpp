#include "store/observation_store.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <set>

namespace maptune::store {
namespace {

namespace fs = std::filesystem;

class StoreTest : public ::testing::Test {
protected:
    void SetUp() override {
        char tmpl[] = "/tmp/maptune_store_test_XXXXXX";
        ASSERT_NE(mkdtemp(tmpl), nullptr);
        dir_ = tmpl;
    }
    void TearDown() override { fs::remove_all(dir_); }
    std::string db_path() const { return (dir_ / "observations.db").string(); }
    fs::path dir_;
};

// A deterministic observation with `n_pairs` pairs; `i` varies the parameters and values.
Observation make_observation(int i, int n_pairs = 20, const std::string& view = "complete") {
    Observation o;
    o.params.set("r_N", 0.1 + 0.01 * (i % 100));
    o.params.set("n_TF", 3 + i % 50);
    o.key = {"dataset-abc", view, "lru_matcher", "1.0",
             "n_TF=" + std::to_string(3 + i % 50) + ";r_N=" + std::to_string(i)};
    for (int p = 0; p < n_pairs; ++p) {
        PairRecord r;
        r.pair_id = "run00/" + std::to_string(p) + "-" + std::to_string(p + 1);
        r.matched = (p + i) % 3 != 0;
        r.T_a_b_est = Eigen::Matrix4d::Identity();
        r.T_a_b_est(0, 3) = i + 0.001 * p;
        r.T_a_b_est(1, 2) = -0.25 * p;
        r.duration_s = 0.01 * p;
        r.status = r.matched ? PairStatus::kOk : (p % 2 ? PairStatus::kNoMatch : PairStatus::kTimeout);
        if (r.status == PairStatus::kTimeout) r.reason = "pair time limit 5 s";
        o.pairs.push_back(r);
    }
    o.wall_seconds = 1.5 + i;
    return o;
}

void expect_same(const Observation& a, const Observation& b) {
    EXPECT_EQ(a.key, b.key);
    EXPECT_EQ(a.params, b.params);
    EXPECT_EQ(a.wall_seconds, b.wall_seconds);
    ASSERT_EQ(a.pairs.size(), b.pairs.size());
    for (std::size_t i = 0; i < a.pairs.size(); ++i) {
        EXPECT_EQ(a.pairs[i].pair_id, b.pairs[i].pair_id);
        EXPECT_EQ(a.pairs[i].matched, b.pairs[i].matched);
        EXPECT_EQ(a.pairs[i].T_a_b_est, b.pairs[i].T_a_b_est);
        EXPECT_EQ(a.pairs[i].duration_s, b.pairs[i].duration_s);
        EXPECT_EQ(a.pairs[i].status, b.pairs[i].status);
        EXPECT_EQ(a.pairs[i].reason, b.pairs[i].reason);
    }
}

TEST_F(StoreTest, PutGetRoundTripsEveryField) {
    ObservationStore store(db_path());
    const Observation o = make_observation(7);
    EXPECT_FALSE(store.get(o.key).has_value());
    EXPECT_TRUE(store.put(o));
    const auto got = store.get(o.key);
    ASSERT_TRUE(got.has_value());
    expect_same(o, *got);
    EXPECT_GT(got->created_unix_ms, 1700000000000);
    EXPECT_GT(got->row_id, 0);
}

TEST_F(StoreTest, PutIsIdempotentAndKeepsTheFirst) {
    ObservationStore store(db_path());
    Observation o = make_observation(1);
    EXPECT_TRUE(store.put(o));
    Observation again = o;
    again.wall_seconds = 99;
    EXPECT_FALSE(store.put(again));
    EXPECT_EQ(store.count(), 1u);
    EXPECT_EQ(store.get(o.key)->wall_seconds, o.wall_seconds);
    // Any key component distinguishes observations.
    Observation other_view = make_observation(1, 20, "subsequent");
    EXPECT_TRUE(store.put(other_view));
    Observation other_version = o;
    other_version.key.matcher_version = "1.1";
    EXPECT_TRUE(store.put(other_version));
    EXPECT_EQ(store.count(), 3u);
}

TEST_F(StoreTest, RemoveDeletesOneObservationAndItsParameterRows) {
    ObservationStore db(db_path());
    ASSERT_TRUE(db.put(make_observation(1)));
    ASSERT_TRUE(db.put(make_observation(2)));
    const auto all = db.list();
    ASSERT_EQ(all.size(), 2u);
    EXPECT_TRUE(db.remove(all[0].row_id));
    EXPECT_FALSE(db.remove(all[0].row_id));
    EXPECT_EQ(db.count(), 1u);
    EXPECT_FALSE(db.get(all[0].key).has_value());
    // A range query touches the parameter index: nothing of the removed one is left there.
    ObservationFilter f;
    f.ranges = {{"r_N", 0.0, 10.0}};
    EXPECT_EQ(db.list(f).size(), 1u);
    EXPECT_TRUE(db.put(make_observation(1)));  // can be stored again
}

TEST_F(StoreTest, ImportCopiesOnlyMissingKeysAndKeepsCreationTimes) {
    ObservationStore a(db_path());
    ObservationStore b((dir_ / "other.db").string());
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(a.put(make_observation(i)));
    ASSERT_TRUE(b.put(make_observation(2)));
    ASSERT_TRUE(b.put(make_observation(7)));
    const auto st = a.import_from(b);
    EXPECT_EQ(st.read, 2u);
    EXPECT_EQ(st.imported, 1u);
    EXPECT_EQ(st.already_present, 1u);
    EXPECT_EQ(a.count(), 4u);
    const auto copied = a.get(make_observation(7).key);
    ASSERT_TRUE(copied.has_value());
    EXPECT_EQ(copied->created_unix_ms, b.get(make_observation(7).key)->created_unix_ms);
    EXPECT_EQ(copied->pairs.size(), make_observation(7).pairs.size());
    EXPECT_EQ(a.import_from(b).imported, 0u);
}

TEST_F(StoreTest, PersistsAcrossReopen) {
    {
        ObservationStore store(db_path());
        for (int i = 0; i < 10; ++i) store.put(make_observation(i));
    }
    ObservationStore store(db_path());
    EXPECT_EQ(store.count(), 10u);
    expect_same(*store.get(make_observation(4).key), make_observation(4));
}

TEST_F(StoreTest, ListFiltersByDatasetViewAndParameterValues) {
    ObservationStore store(db_path());
    for (int i = 0; i < 30; ++i) store.put(make_observation(i, 2, i % 2 ? "complete" : "subsequent"));
    Observation foreign = make_observation(100, 2);
    foreign.key.dataset_id = "other";
    store.put(foreign);

    EXPECT_EQ(store.list().size(), 31u);
    ObservationFilter f;
    f.dataset_id = "dataset-abc";
    EXPECT_EQ(store.list(f).size(), 30u);
    f.view = "complete";
    const auto complete = store.list(f);
    EXPECT_EQ(complete.size(), 15u);
    for (const auto& o : complete) EXPECT_EQ(o.key.view, "complete");
    // r_N = 0.1 + 0.01 i in [0.2, 0.25] → i in 10..15, odd → 11, 13, 15.
    f.ranges.push_back({"r_N", 0.195, 0.255});
    const auto ranged = store.list(f);
    ASSERT_EQ(ranged.size(), 3u);
    EXPECT_NEAR(ranged[0].params.get("r_N"), 0.21, 1e-12);
    f.ranges.push_back({"n_TF", 16, 16});  // i = 13
    ASSERT_EQ(store.list(f).size(), 1u);
    f = {};
    f.limit = 5;
    EXPECT_EQ(store.list(f).size(), 5u);
}

TEST_F(StoreTest, ForeignFileIsRefusedAndNeverOverwritten) {
    const std::string path = db_path();
    {
        std::ofstream out(path);
        out << "robot_name: rover\nthis is a YAML file, not a database\n";
    }
    const auto before = fs::file_size(path);
    try {
        ObservationStore store(path);
        FAIL() << "opened a foreign file";
    } catch (const StoreError& e) {
        EXPECT_NE(std::string(e.what()).find("not an SQLite database"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos);
    }
    EXPECT_EQ(fs::file_size(path), before);
}

// Issue 14: listing an empty file turned it into a store. Read-only opening writes nothing:
// no store is created, an empty or missing file is an error, a real store reads as usual.
TEST_F(StoreTest, ReadOnlyOpeningNeverWrites) {
    const std::string path = db_path();
    EXPECT_THROW(ObservationStore(path, ObservationStore::Mode::kReadOnly), StoreError);
    EXPECT_FALSE(fs::exists(path));
    std::ofstream(path).close();
    try {
        ObservationStore store(path, ObservationStore::Mode::kReadOnly);
        FAIL() << "opened an empty file";
    } catch (const StoreError& e) {
        EXPECT_NE(std::string(e.what()).find("empty file"), std::string::npos) << e.what();
    }
    EXPECT_EQ(fs::file_size(path), 0u);
    fs::remove(path);
    {
        ObservationStore store(path);
        store.put(make_observation(1));
    }
    const auto before = fs::last_write_time(path);
    const ObservationStore reader(path, ObservationStore::Mode::kReadOnly);
    EXPECT_EQ(reader.count(), 1u);
    EXPECT_EQ(fs::last_write_time(path), before);
}

TEST_F(StoreTest, ForeignSqliteDatabaseIsRefused) {
    const std::string path = db_path();
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE robots(name TEXT); INSERT INTO robots VALUES('lru');",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
    EXPECT_THROW({ ObservationStore store(path); }, StoreError);
    // Still the other application's data.
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    EXPECT_EQ(sqlite3_exec(db, "SELECT name FROM robots", nullptr, nullptr, nullptr), SQLITE_OK);
    EXPECT_NE(sqlite3_exec(db, "SELECT * FROM observations", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
}

TEST_F(StoreTest, CorruptDatabaseIsAClearError) {
    const std::string path = db_path();
    {
        ObservationStore store(path);
        for (int i = 0; i < 50; ++i) store.put(make_observation(i, 40));
    }
    // Overwrite pages after the header with garbage, as a failing disk would.
    const auto size = fs::file_size(path);
    {
        std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
        std::mt19937 rng(3);
        for (std::uintmax_t off = 4096; off < size; off += 4096) {
            f.seekp(static_cast<std::streamoff>(off));
            for (int i = 0; i < 200; ++i) f.put(static_cast<char>(rng()));
        }
    }
    const auto before = fs::last_write_time(path);
    try {
        ObservationStore store(path);
        // quick_check may not catch every corruption in row data; reading must then fail
        // cleanly rather than crash.
        EXPECT_THROW(store.list(), StoreError);
    } catch (const StoreError& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
    EXPECT_EQ(fs::last_write_time(path), before);
}

TEST_F(StoreTest, NewerSchemaIsRefused) {
    const std::string path = db_path();
    { ObservationStore store(path); }
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    sqlite3_exec(db, "PRAGMA user_version=99", nullptr, nullptr, nullptr);
    sqlite3_close(db);
    try {
        ObservationStore store(path);
        FAIL();
    } catch (const StoreError& e) {
        EXPECT_NE(std::string(e.what()).find("schema version 99"), std::string::npos);
    }
}

// Durability: a child writes observations as fast as it can and reports each commit on a
// pipe; it is SIGKILLed mid-stream. Every reported observation must be intact after reopen,
// and nothing partial may be visible.
TEST_F(StoreTest, SigkillDuringWritesLosesNoCommittedObservation) {
    const std::string path = db_path();
    { ObservationStore init(path); }
    int fds[2];
    ASSERT_EQ(pipe(fds), 0);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        close(fds[0]);
        try {
            ObservationStore store(path);
            for (int i = 0;; ++i) {
                store.put(make_observation(i, 200));  // ~30 kB records: writes span pages
                if (write(fds[1], &i, sizeof(i)) != sizeof(i)) _exit(3);
            }
        } catch (...) {
            _exit(2);
        }
    }
    close(fds[1]);
    std::set<int> committed;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    int i = 0;
    while (committed.size() < 40 && std::chrono::steady_clock::now() < deadline &&
           read(fds[0], &i, sizeof(i)) == sizeof(i)) {
        committed.insert(i);
    }
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
    // Commits reported between our last read and the kill.
    while (read(fds[0], &i, sizeof(i)) == sizeof(i)) committed.insert(i);
    close(fds[0]);
    ASSERT_TRUE(WIFSIGNALED(status)) << "child exited on its own with " << WEXITSTATUS(status);
    ASSERT_GE(committed.size(), 40u);

    ObservationStore store(path);
    const auto all = store.list();
    EXPECT_GE(all.size(), committed.size());
    EXPECT_LE(all.size(), committed.size() + 1);  // at most the one in flight, whole
    for (int c : committed) {
        const auto got = store.get(make_observation(c, 200).key);
        ASSERT_TRUE(got.has_value()) << "committed observation " << c << " lost";
        expect_same(make_observation(c, 200), *got);
    }
    for (const auto& o : all) EXPECT_EQ(o.pairs.size(), 200u);
    // The store stays writable after the crash.
    EXPECT_TRUE(store.put(make_observation(100000, 3)));
}

}  // namespace
}  // namespace maptune::store

namespace maptune::store {
namespace {

TEST(PairRecordCheck, AcceptsRigidTransformsAndNamesWhatIsBroken) {
    PairRecord r;
    r.pair_id = "a|b";
    r.matched = true;
    r.T_a_b_est.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    r.T_a_b_est(0, 3) = 4.0;
    EXPECT_EQ(check_pair_record(r), "");
    // What a float matcher returns: the same transform composed in float a few times.
    PairRecord single = r;
    Eigen::Matrix4f f = r.T_a_b_est.cast<float>();
    for (int i = 0; i < 50; ++i) f = f * Eigen::Matrix4f(r.T_a_b_est.inverse().cast<float>()) * r.T_a_b_est.cast<float>();
    single.T_a_b_est = f.cast<double>();
    EXPECT_EQ(check_pair_record(single), "");
    PairRecord nan = r;
    nan.T_a_b_est(1, 3) = std::nan("");
    EXPECT_NE(check_pair_record(nan).find("a|b: transform has a NaN"), std::string::npos);
    PairRecord inf = r;
    inf.T_a_b_est(0, 0) = std::numeric_limits<double>::infinity();
    EXPECT_NE(check_pair_record(inf), "");
    PairRecord scaled = r;
    scaled.T_a_b_est.topLeftCorner<3, 3>() *= 1.01;
    EXPECT_NE(check_pair_record(scaled).find("not orthonormal"), std::string::npos);
    PairRecord mirrored = r;
    mirrored.T_a_b_est.row(2) *= -1.0;  // a reflection: orthonormal, determinant -1
    mirrored.T_a_b_est(3, 3) = 1.0;
    EXPECT_NE(check_pair_record(mirrored), "");
    PairRecord bottom = r;
    bottom.T_a_b_est(3, 0) = 0.5;
    EXPECT_NE(check_pair_record(bottom).find("bottom row"), std::string::npos);
    PairRecord unmatched = nan;  // an unmatched pair's transform means nothing
    unmatched.matched = false;
    EXPECT_EQ(check_pair_record(unmatched), "");
    PairRecord slow = r;
    slow.duration_s = -1;
    EXPECT_NE(check_pair_record(slow).find("duration"), std::string::npos);
}

}  // namespace
}  // namespace maptune::store
