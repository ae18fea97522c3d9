#include "store/observation_store.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include <sqlite3.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "observation.pb.h"

namespace maptune::store {
namespace {

// PRAGMA application_id marks our files, so a foreign SQLite database is never written to.
constexpr int kApplicationId = 0x4d50544e;  // "MPTN"
constexpr int kSchemaVersion = 1;

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS observations (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  dataset_id TEXT NOT NULL,
  view TEXT NOT NULL,
  matcher_id TEXT NOT NULL,
  matcher_version TEXT NOT NULL,
  params_key TEXT NOT NULL,
  created_unix_ms INTEGER NOT NULL,
  record BLOB NOT NULL,
  UNIQUE (dataset_id, view, matcher_id, matcher_version, params_key)
);
CREATE TABLE IF NOT EXISTS observation_params (
  observation_id INTEGER NOT NULL REFERENCES observations(id),
  name TEXT NOT NULL,
  value REAL NOT NULL,
  PRIMARY KEY (observation_id, name)
);
CREATE INDEX IF NOT EXISTS observation_params_by_value ON observation_params(name, value);
)sql";

std::int64_t now_unix_ms() {
    return std::chrono::duration_cast<std::chrono::milliseconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
}

v1::PairStatus to_proto(PairStatus s) {
    switch (s) {
        case PairStatus::kOk: return v1::PAIR_STATUS_OK;
        case PairStatus::kNoMatch: return v1::PAIR_STATUS_NO_MATCH;
        case PairStatus::kFailed: return v1::PAIR_STATUS_FAILED;
        case PairStatus::kTimeout: return v1::PAIR_STATUS_TIMEOUT;
    }
    return v1::PAIR_STATUS_UNSPECIFIED;
}

PairStatus from_proto(v1::PairStatus s) {
    switch (s) {
        case v1::PAIR_STATUS_NO_MATCH: return PairStatus::kNoMatch;
        case v1::PAIR_STATUS_FAILED: return PairStatus::kFailed;
        case v1::PAIR_STATUS_TIMEOUT: return PairStatus::kTimeout;
        default: return PairStatus::kOk;
    }
}

std::string encode(const Observation& o) {
    v1::ObservationRecord r;
    r.set_format_version(1);
    r.set_dataset_id(o.key.dataset_id);
    r.set_view(o.key.view);
    r.set_matcher_id(o.key.matcher_id);
    r.set_matcher_version(o.key.matcher_version);
    r.set_params_key(o.key.params_key);
    for (const auto& [name, value] : o.params) {
        auto* nv = r.add_params();
        nv->set_name(name);
        nv->set_value(value);
    }
    for (const auto& p : o.pairs) {
        auto* pr = r.add_pairs();
        pr->set_pair_id(p.pair_id);
        pr->set_matched(p.matched);
        for (int row = 0; row < 4; ++row) {
            for (int col = 0; col < 4; ++col) pr->add_t_a_b(p.T_a_b_est(row, col));
        }
        pr->set_duration_s(p.duration_s);
        pr->set_status(to_proto(p.status));
        pr->set_reason(p.reason);
    }
    r.set_wall_seconds(o.wall_seconds);
    r.set_created_unix_ms(o.created_unix_ms);
    std::string bytes;
    if (!r.SerializeToString(&bytes)) throw StoreError("cannot serialize observation");
    return bytes;
}

Observation decode(const void* data, int size, std::int64_t row_id, const std::string& db) {
    v1::ObservationRecord r;
    const std::string where = db + ": observation row " + std::to_string(row_id);
    if (!r.ParseFromArray(data, size)) throw StoreError(where + ": record does not parse");
    if (r.format_version() != 1) {
        throw StoreError(where + ": unknown record format " + std::to_string(r.format_version()));
    }
    Observation o;
    o.row_id = row_id;
    o.key = {r.dataset_id(), r.view(), r.matcher_id(), r.matcher_version(), r.params_key()};
    for (const auto& nv : r.params()) o.params.set(nv.name(), nv.value());
    for (const auto& pr : r.pairs()) {
        if (pr.t_a_b_size() != 16) {
            throw StoreError(where + ": pair '" + pr.pair_id() + "' has " +
                             std::to_string(pr.t_a_b_size()) + " transform values, expected 16");
        }
        PairRecord p;
        p.pair_id = pr.pair_id();
        p.matched = pr.matched();
        for (int i = 0; i < 16; ++i) p.T_a_b_est(i / 4, i % 4) = pr.t_a_b(i);
        p.duration_s = pr.duration_s();
        p.status = from_proto(pr.status());
        p.reason = pr.reason();
        o.pairs.push_back(std::move(p));
    }
    o.wall_seconds = r.wall_seconds();
    o.created_unix_ms = r.created_unix_ms();
    return o;
}

// A prepared statement that finalizes itself.
class Statement {
public:
    Statement(sqlite3* db, const std::string& sql, const std::string& path) : db_(db) {
        if (sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt_, nullptr) != SQLITE_OK) {
            throw StoreError(path + ": " + sqlite3_errmsg(db) + " (in: " + sql + ")");
        }
    }
    ~Statement() { sqlite3_finalize(stmt_); }
    Statement(const Statement&) = delete;
    Statement& operator=(const Statement&) = delete;
    void bind(int i, const std::string& s) {
        sqlite3_bind_text(stmt_, i, s.c_str(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
    }
    void bind(int i, double v) { sqlite3_bind_double(stmt_, i, v); }
    void bind(int i, std::int64_t v) { sqlite3_bind_int64(stmt_, i, v); }
    void bind_blob(int i, const std::string& b) {
        sqlite3_bind_blob(stmt_, i, b.data(), static_cast<int>(b.size()), SQLITE_TRANSIENT);
    }
    // True while rows come; throws on errors.
    bool step(const std::string& path) {
        const int rc = sqlite3_step(stmt_);
        if (rc == SQLITE_ROW) return true;
        if (rc == SQLITE_DONE) return false;
        throw StoreError(path + ": " + sqlite3_errmsg(db_));
    }
    sqlite3_stmt* get() { return stmt_; }

private:
    sqlite3* db_;
    sqlite3_stmt* stmt_ = nullptr;
};

}  // namespace

const char* to_string(PairStatus status) {
    switch (status) {
        case PairStatus::kOk: return "OK";
        case PairStatus::kNoMatch: return "NO_MATCH";
        case PairStatus::kFailed: return "FAILED";
        case PairStatus::kTimeout: return "TIMEOUT";
    }
    return "UNKNOWN";
}

std::string check_pair_record(const PairRecord& r) {
    if (!std::isfinite(r.duration_s) || r.duration_s < 0) return r.pair_id + ": duration is not a finite number >= 0";
    if (!r.matched) return "";
    if (!r.T_a_b_est.allFinite()) return r.pair_id + ": transform has a NaN or infinite entry";
    const Eigen::Matrix3d R = r.T_a_b_est.topLeftCorner<3, 3>();
    // Matchers compute in float (PCL's Matrix4f, composed over RANSAC and ICP): their
    // rotations are orthonormal to ~1e-5 only. 1e-3 accepts every such result and still
    // rejects any real scaling, shear or garbage.
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-3 ||
        std::abs(R.determinant() - 1.0) > 1e-3) {
        return r.pair_id + ": rotation is not orthonormal with determinant 1";
    }
    if ((r.T_a_b_est.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
        return r.pair_id + ": bottom row is not 0 0 0 1";
    }
    return "";
}

bool has_timeouts(const std::vector<PairRecord>& pairs) {
    return std::any_of(pairs.begin(), pairs.end(), [](const PairRecord& p) { return p.status == PairStatus::kTimeout; });
}

bool ObservationKey::operator==(const ObservationKey& o) const {
    return dataset_id == o.dataset_id && view == o.view && matcher_id == o.matcher_id &&
           matcher_version == o.matcher_version && params_key == o.params_key;
}

struct ObservationStore::Impl {
    std::string path;
    sqlite3* db = nullptr;

    ~Impl() {
        if (db != nullptr) sqlite3_close_v2(db);
    }

    void exec(const std::string& sql) const {
        char* err = nullptr;
        if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
            std::string msg = err != nullptr ? err : sqlite3_errmsg(db);
            sqlite3_free(err);
            throw StoreError(path + ": " + msg);
        }
    }

    std::int64_t pragma_int(const std::string& name) const {
        Statement st(db, "PRAGMA " + name, path);
        return st.step(path) ? sqlite3_column_int64(st.get(), 0) : 0;
    }

    std::vector<Observation> query(const std::string& where_sql,
                                   const std::vector<std::string>& binds_text,
                                   const std::vector<ParamRange>& ranges,
                                   std::size_t limit) const {
        std::string sql = "SELECT id, record FROM observations o WHERE 1=1" + where_sql;
        for (std::size_t i = 0; i < ranges.size(); ++i) {
            sql += " AND EXISTS (SELECT 1 FROM observation_params q WHERE q.observation_id = o.id"
                   " AND q.name = ? AND q.value BETWEEN ? AND ?)";
        }
        sql += " ORDER BY id";
        if (limit > 0) sql += " LIMIT " + std::to_string(limit);
        Statement st(db, sql, path);
        int i = 1;
        for (const auto& b : binds_text) st.bind(i++, b);
        for (const auto& r : ranges) {
            st.bind(i++, r.name);
            st.bind(i++, r.low);
            st.bind(i++, r.high);
        }
        std::vector<Observation> out;
        while (st.step(path)) {
            const auto id = sqlite3_column_int64(st.get(), 0);
            const void* blob = sqlite3_column_blob(st.get(), 1);
            const int size = sqlite3_column_bytes(st.get(), 1);
            out.push_back(decode(blob, size, id, path));
        }
        return out;
    }
};

ObservationStore::ObservationStore(const std::string& path, Mode mode) : impl_(std::make_unique<Impl>()) {
    impl_->path = path;
    namespace fs = std::filesystem;
    std::error_code ec;
    const bool exists = fs::exists(path, ec);
    const bool read_only = mode == Mode::kReadOnly;
    if (read_only && !exists) throw StoreError(path + ": no such file");
    if (read_only && fs::is_regular_file(path, ec) && fs::file_size(path, ec) == 0) {
        throw StoreError(path + ": empty file, not an observation store");
    }
    if (exists) {
        if (!fs::is_regular_file(path, ec)) throw StoreError(path + ": not a regular file");
        if (fs::file_size(path, ec) > 0) {
            // Check the header ourselves: SQLite would happily treat some foreign files as
            // empty databases on first write.
            char header[16] = {};
            std::ifstream in(path, std::ios::binary);
            in.read(header, sizeof(header));
            if (!in || std::memcmp(header, "SQLite format 3", 16) != 0) {
                throw StoreError(path +
                                 ": not an SQLite database (foreign or corrupt file); "
                                 "refusing to open it as an observation store");
            }
        }
    }
    const int flags = (read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE | (exists ? 0 : SQLITE_OPEN_CREATE)) |
                      SQLITE_OPEN_FULLMUTEX;
    if (sqlite3_open_v2(path.c_str(), &impl_->db, flags, nullptr) != SQLITE_OK) {
        throw StoreError(path + ": cannot open: " + sqlite3_errmsg(impl_->db));
    }
    sqlite3_busy_timeout(impl_->db, 10000);
    try {
        // Reading the schema validates the database header and pages.
        const auto app_id = impl_->pragma_int("application_id");
        const auto tables = impl_->pragma_int("schema_version");
        if (app_id != 0 && app_id != kApplicationId) {
            throw StoreError(path + ": SQLite database of another application (application_id " +
                             std::to_string(app_id) + "); refusing to use it");
        }
        if (app_id == 0 && tables != 0) {
            throw StoreError(path + ": SQLite database without maptune's application_id; "
                                    "refusing to use it");
        }
        {  // scoped: an unfinished statement would hold a read transaction open
            Statement check(impl_->db, "PRAGMA quick_check", path);
            if (check.step(path)) {
                const auto* text =
                    reinterpret_cast<const char*>(sqlite3_column_text(check.get(), 0));
                if (text == nullptr || std::string(text) != "ok") {
                    throw StoreError(path + ": database is corrupt: " + (text ? text : "?"));
                }
            }
        }
        const auto version = impl_->pragma_int("user_version");
        if (version > kSchemaVersion) {
            throw StoreError(path + ": schema version " + std::to_string(version) +
                             " is newer than this maptune understands (" +
                             std::to_string(kSchemaVersion) + ")");
        }
        if (read_only) {
            if (app_id != kApplicationId) throw StoreError(path + ": not a maptune observation store");
            return;
        }
        impl_->exec("PRAGMA journal_mode=WAL");
        // FULL: a committed observation survives a crash of the process and of the machine.
        impl_->exec("PRAGMA synchronous=FULL");
        impl_->exec("PRAGMA foreign_keys=ON");
        if (app_id == 0) {
            impl_->exec("BEGIN IMMEDIATE");
            impl_->exec(kSchema);
            impl_->exec("PRAGMA application_id=" + std::to_string(kApplicationId));
            impl_->exec("PRAGMA user_version=" + std::to_string(kSchemaVersion));
            impl_->exec("COMMIT");
        }
    } catch (const StoreError& e) {
        const std::string msg = e.what();
        const int code = sqlite3_errcode(impl_->db);
        if (code == SQLITE_NOTADB || code == SQLITE_CORRUPT) {
            throw StoreError(path + ": database is corrupt or not a database: " + msg);
        }
        throw;
    }
}

ObservationStore::~ObservationStore() = default;
ObservationStore::ObservationStore(ObservationStore&&) noexcept = default;
ObservationStore& ObservationStore::operator=(ObservationStore&&) noexcept = default;

const std::string& ObservationStore::path() const { return impl_->path; }

std::optional<Observation> ObservationStore::get(const ObservationKey& key) const {
    auto rows = impl_->query(
        " AND dataset_id = ? AND view = ? AND matcher_id = ? AND matcher_version = ?"
        " AND params_key = ?",
        {key.dataset_id, key.view, key.matcher_id, key.matcher_version, key.params_key}, {}, 1);
    if (rows.empty()) return std::nullopt;
    return std::move(rows.front());
}

std::vector<Observation> ObservationStore::other_views(const ObservationKey& key) const {
    return impl_->query(
        " AND dataset_id = ? AND matcher_id = ? AND matcher_version = ? AND params_key = ? AND view <> ?",
        {key.dataset_id, key.matcher_id, key.matcher_version, key.params_key, key.view}, {}, 0);
}

bool ObservationStore::put(const Observation& observation) {
    Observation o = observation;
    if (o.created_unix_ms == 0) o.created_unix_ms = now_unix_ms();
    const std::string blob = encode(o);
    const std::string& path = impl_->path;
    impl_->exec("BEGIN IMMEDIATE");
    try {
        Statement ins(impl_->db,
                      "INSERT OR IGNORE INTO observations (dataset_id, view, matcher_id, "
                      "matcher_version, params_key, created_unix_ms, record) "
                      "VALUES (?, ?, ?, ?, ?, ?, ?)",
                      path);
        ins.bind(1, o.key.dataset_id);
        ins.bind(2, o.key.view);
        ins.bind(3, o.key.matcher_id);
        ins.bind(4, o.key.matcher_version);
        ins.bind(5, o.key.params_key);
        ins.bind(6, o.created_unix_ms);
        ins.bind_blob(7, blob);
        ins.step(path);
        const bool inserted = sqlite3_changes(impl_->db) > 0;
        if (inserted) {
            const auto id = sqlite3_last_insert_rowid(impl_->db);
            Statement par(impl_->db,
                          "INSERT INTO observation_params (observation_id, name, value) "
                          "VALUES (?, ?, ?)",
                          path);
            for (const auto& [name, value] : o.params) {
                sqlite3_reset(par.get());
                par.bind(1, static_cast<std::int64_t>(id));
                par.bind(2, name);
                par.bind(3, value);
                par.step(path);
            }
        }
        impl_->exec("COMMIT");
        return inserted;
    } catch (...) {
        sqlite3_exec(impl_->db, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
    }
}

std::vector<Observation> ObservationStore::list(const ObservationFilter& filter) const {
    std::string where;
    std::vector<std::string> binds;
    if (filter.dataset_id) {
        where += " AND dataset_id = ?";
        binds.push_back(*filter.dataset_id);
    }
    if (filter.view) {
        where += " AND view = ?";
        binds.push_back(*filter.view);
    }
    if (filter.matcher_id) {
        where += " AND matcher_id = ?";
        binds.push_back(*filter.matcher_id);
    }
    return impl_->query(where, binds, filter.ranges, filter.limit);
}

bool ObservationStore::remove(std::int64_t row_id) {
    const std::string& path = impl_->path;
    impl_->exec("BEGIN IMMEDIATE");
    try {
        Statement par(impl_->db, "DELETE FROM observation_params WHERE observation_id = ?", path);
        par.bind(1, row_id);
        par.step(path);
        Statement obs(impl_->db, "DELETE FROM observations WHERE id = ?", path);
        obs.bind(1, row_id);
        obs.step(path);
        const bool removed = sqlite3_changes(impl_->db) > 0;
        impl_->exec("COMMIT");
        return removed;
    } catch (...) {
        sqlite3_exec(impl_->db, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
    }
}

ObservationStore::ImportStats ObservationStore::import_from(const ObservationStore& other) {
    ImportStats stats;
    for (auto& o : other.list()) {
        ++stats.read;
        o.row_id = 0;  // keeps created_unix_ms: when the matcher ran
        if (put(o)) ++stats.imported;
        else ++stats.already_present;
    }
    return stats;
}

std::size_t ObservationStore::count() const {
    Statement st(impl_->db, "SELECT COUNT(*) FROM observations", impl_->path);
    return st.step(impl_->path) ? static_cast<std::size_t>(sqlite3_column_int64(st.get(), 0)) : 0;
}

}  // namespace maptune::store
