#include "experiment/run_files.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

#include "params/yaml_util.hpp"

namespace maptune::experiment {

namespace fs = std::filesystem;
using params::YamlPath;

std::vector<std::string> split_csv_line(const std::string& line) {
    std::vector<std::string> out;
    std::string cell;
    std::istringstream in(line);
    while (std::getline(in, cell, ',')) out.push_back(cell);
    if (!line.empty() && line.back() == ',') out.emplace_back();
    return out;
}

int baseline_index(const Experiment& e, const std::vector<EvaluationRecord>& records) {
    if (e.start_points.empty()) return -1;
    const std::string key = e.space.canonical_key(e.space.round(e.start_points.front()));
    for (std::size_t i = 0; i < records.size(); ++i) {
        if (!records[i].failed && e.space.canonical_key(records[i].params) == key) return static_cast<int>(i);
    }
    return -1;
}

double record_objective(const Experiment& e, const EvaluationRecord& r) {
    return r.failed ? r.p : objective(e, r.p, r.pair_s);
}

int best_index(const Experiment& e, const std::vector<EvaluationRecord>& records) {
    int best = -1;
    for (std::size_t i = 0; i < records.size(); ++i) {
        const auto& r = records[i];
        if (r.failed || r.fidelity != 1) continue;
        if (best < 0 ||
            better(e, record_objective(e, r), record_objective(e, records[static_cast<std::size_t>(best)]))) {
            best = static_cast<int>(i);
        }
    }
    return best;
}

std::string trials_csv(const std::vector<EvaluationRecord>& records, const params::ParameterSpace& space) {
    std::ostringstream out;
    out << "evaluation,p,m,v,eps,failed,from_store,wall_s,pair_s,fidelity,elapsed_s,origin";
    for (const auto& s : space.specs()) out << "," << s.name;
    out << ",error\n";
    for (const auto& r : records) {
        out << r.number << "," << params::format_double(r.p) << "," << r.m << ","
            << params::format_double(r.v) << "," << params::format_double(r.eps) << ","
            << (r.failed ? 1 : 0) << "," << (r.from_store ? 1 : 0) << "," << params::format_fixed(r.wall_s, 3) << ","
            << params::format_double(r.pair_s) << "," << r.fidelity << "," << params::format_fixed(r.elapsed_s, 3)
            << "," << r.origin;
        for (const auto& s : space.specs()) {
            const auto v = r.params.find(s.name);
            out << "," << (v ? params::format_double(*v) : "");
        }
        std::string error = r.error;
        for (char& c : error) c = (c == ',' || c == '\n') ? ';' : c;
        out << "," << error << "\n";
    }
    return out.str();
}

std::vector<EvaluationRecord> read_trials_csv(const fs::path& file, const params::ParameterSpace& space) {
    std::vector<EvaluationRecord> out;
    std::ifstream in(file);
    if (!in) return out;
    std::string line;
    std::getline(in, line);
    const auto header = split_csv_line(line);
    // Columns between wall_s and origin came one by one (pair_s, then fidelity and elapsed_s):
    // files written before a column resume with its default.
    const auto origin_at = std::find(header.begin(), header.end(), "origin");
    const std::size_t first_param = static_cast<std::size_t>(origin_at - header.begin()) + 1;
    auto optional_column = [&](const char* name) -> std::optional<std::size_t> {
        const auto it = std::find(header.begin(), origin_at, name);
        if (it == origin_at) return std::nullopt;
        return static_cast<std::size_t>(it - header.begin());
    };
    const auto pair_s_at = optional_column("pair_s");
    const auto fidelity_at = optional_column("fidelity");
    const auto elapsed_at = optional_column("elapsed_s");
    const std::size_t optional_columns = (pair_s_at ? 1 : 0) + (fidelity_at ? 1 : 0) + (elapsed_at ? 1 : 0);
    if (header.size() < 9 || origin_at == header.end() || first_param != 9 + optional_columns ||
        header.size() != first_param + space.size() + 1) {
        throw params::ConfigError(file.string() + ":1: header does not match the design space; "
                                  "use another run directory");
    }
    int line_no = 1;
    while (std::getline(in, line)) {
        ++line_no;
        const auto c = split_csv_line(line);
        if (c.size() != header.size()) {
            throw params::ConfigError(file.string() + ":" + std::to_string(line_no) + ": expected " +
                                      std::to_string(header.size()) + " columns");
        }
        // Whole cells only, and finite: a NaN p resumed into the best-so-far printed garbage.
        auto number = [](const std::string& cell) {
            std::size_t used = 0;
            const double v = std::stod(cell, &used);
            if (used != cell.size() || !std::isfinite(v)) throw std::invalid_argument(cell);
            return v;
        };
        try {
            EvaluationRecord r;
            r.number = std::stoi(c[0]);
            r.p = number(c[1]);
            r.m = std::stoul(c[2]);
            r.v = number(c[3]);
            r.eps = number(c[4]);
            r.failed = c[5] == "1";
            r.from_store = c[6] == "1";
            r.wall_s = number(c[7]);
            if (pair_s_at) r.pair_s = number(c[*pair_s_at]);
            if (r.pair_s < 0) throw std::invalid_argument("pair_s");
            if (fidelity_at) r.fidelity = std::stoi(c[*fidelity_at]);
            if (r.fidelity < 1) throw std::invalid_argument("fidelity");
            if (elapsed_at) r.elapsed_s = number(c[*elapsed_at]);
            r.origin = c[first_param - 1];
            for (std::size_t i = 0; i < space.size(); ++i) {
                r.params.set(space.specs()[i].name, number(c[first_param + i]));
            }
            r.error = c.back();
            out.push_back(std::move(r));
        } catch (const std::exception&) {
            throw params::ConfigError(file.string() + ":" + std::to_string(line_no) + ": not a finite number");
        }
    }
    return out;
}

RunRecord read_run_record(const fs::path& run_dir) {
    const fs::path file = run_dir / "run.yaml";
    if (!fs::exists(file)) {
        throw params::ConfigError(file.string() +
                                  ": missing (not a run directory of this maptune version; give --experiment)");
    }
    const YAML::Node root = params::load_yaml_file(file.string());
    const params::YamlPath where{file.string(), ""};
    params::require_map(root, where);
    auto text = [&](const YAML::Node& n, const YamlPath& p) { return n.IsDefined() ? params::read_string(n, p) : ""; };
    RunRecord r;
    r.experiment_file = text(root["experiment_file"], where.child("experiment_file"));
    r.state = text(root["state"], where.child("state"));
    if (const YAML::Node d = root["dataset"]; d.IsDefined()) {
        const auto p = where.child("dataset");
        params::require_map(d, p);
        r.dataset_dir = text(d["dir"], p.child("dir"));
        r.dataset_id = text(d["id"], p.child("id"));
        r.view = text(d["view"], p.child("view"));
        r.reference = text(d["reference"], p.child("reference"));
    }
    if (const YAML::Node m = root["matcher"]; m.IsDefined()) {
        const auto p = where.child("matcher");
        params::require_map(m, p);
        r.matcher_id = text(m["id"], p.child("id"));
        r.matcher_version = text(m["version"], p.child("version"));
    }
    if (const YAML::Node s = root["space"]; s.IsDefined()) {
        const auto p = where.child("space");
        params::require_map(s, p);
        r.space_hash = text(s["hash"], p.child("hash"));
    }
    if (root["measure"].IsDefined() && root["measure"]["m_star"].IsDefined()) {
        r.m_star = params::read_finite_double(root["measure"]["m_star"], where.child("measure").child("m_star"));
    }
    if (root["best"].IsDefined() && root["best"]["p"].IsDefined()) {
        r.best_p = params::read_finite_double(root["best"]["p"], where.child("best").child("p"));
    }
    return r;
}

std::string recorded_experiment_file(const fs::path& run_dir) {
    const std::string file = read_run_record(run_dir).experiment_file;
    if (file.empty() || !fs::exists(file)) {
        throw params::ConfigError((run_dir / "run.yaml").string() + ": experiment_file: '" + file +
                                  "' is not there any more; give --experiment");
    }
    return file;
}

store::ObservationKey observation_key(const RunRecord& run, const params::ParameterSpace& space,
                                      const params::ParameterSet& set) {
    return {run.dataset_id, run.view, run.matcher_id, run.matcher_version,
            space.canonical_key(space.round(space.complete(set)))};
}

std::vector<std::pair<std::uint64_t, fs::path>> seed_run_dirs(const fs::path& root) {
    std::vector<std::pair<std::uint64_t, fs::path>> out;
    if (!fs::is_directory(root)) return out;
    for (const auto& entry : fs::directory_iterator(root)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind("seed-", 0) != 0 || !fs::exists(entry.path() / "run.yaml")) continue;
        try {
            out.push_back({std::stoull(name.substr(5)), entry.path()});
        } catch (const std::exception&) {
            // not a seed directory
        }
    }
    std::sort(out.begin(), out.end());
    return out;
}

std::vector<fs::path> expand_run_dirs(const std::vector<fs::path>& dirs) {
    std::vector<fs::path> out;
    for (const auto& d : dirs) {
        if (fs::exists(d / "run.yaml")) {
            out.push_back(d);
            continue;
        }
        const auto seeds = experiment::seed_run_dirs(d);
        if (seeds.empty()) {
            throw params::ConfigError(d.string() + ": not a run directory (no run.yaml, no seed-*/run.yaml)");
        }
        for (const auto& s : seeds) out.push_back(s.second);
    }
    return out;
}

std::string run_store_path(const fs::path& run_dir) {
    for (const fs::path& p : {run_dir / "observations.db", run_dir.parent_path() / "observations.db"}) {
        if (fs::exists(p)) return p.string();
    }
    return "";
}

}  // namespace maptune::experiment
