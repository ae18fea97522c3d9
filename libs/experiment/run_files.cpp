#include "experiment/run_files.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "params/yaml_util.hpp"

namespace maptune::experiment {

namespace fs = std::filesystem;

namespace {

std::vector<std::string> split(const std::string& line, char sep) {
    std::vector<std::string> out;
    std::string cell;
    std::istringstream in(line);
    while (std::getline(in, cell, sep)) out.push_back(cell);
    if (!line.empty() && line.back() == sep) out.emplace_back();
    return out;
}

}  // namespace

std::string trials_csv(const std::vector<EvaluationRecord>& records, const params::ParameterSpace& space) {
    std::ostringstream out;
    out << "evaluation,p,m,v,eps,failed,from_store,wall_s,origin";
    for (const auto& s : space.specs()) out << "," << s.name;
    out << ",error\n";
    for (const auto& r : records) {
        out << r.number << "," << params::format_double(r.p) << "," << r.m << ","
            << params::format_double(r.v) << "," << params::format_double(r.eps) << ","
            << (r.failed ? 1 : 0) << "," << (r.from_store ? 1 : 0) << "," << params::format_fixed(r.wall_s, 3) << ","
            << r.origin;
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
    const auto header = split(line, ',');
    const std::size_t first_param = 9;
    if (header.size() != first_param + space.size() + 1) {
        throw params::ConfigError(file.string() + ":1: header does not match the design space; "
                                  "use another run directory");
    }
    int line_no = 1;
    while (std::getline(in, line)) {
        ++line_no;
        const auto c = split(line, ',');
        if (c.size() != header.size()) {
            throw params::ConfigError(file.string() + ":" + std::to_string(line_no) + ": expected " +
                                      std::to_string(header.size()) + " columns");
        }
        try {
            EvaluationRecord r;
            r.number = std::stoi(c[0]);
            r.p = std::stod(c[1]);
            r.m = std::stoul(c[2]);
            r.v = std::stod(c[3]);
            r.eps = std::stod(c[4]);
            r.failed = c[5] == "1";
            r.from_store = c[6] == "1";
            r.wall_s = std::stod(c[7]);
            r.origin = c[8];
            for (std::size_t i = 0; i < space.size(); ++i) {
                r.params.set(space.specs()[i].name, std::stod(c[first_param + i]));
            }
            r.error = c.back();
            out.push_back(std::move(r));
        } catch (const std::exception&) {
            throw params::ConfigError(file.string() + ":" + std::to_string(line_no) + ": not a number");
        }
    }
    return out;
}

std::string recorded_experiment_file(const fs::path& run_dir) {
    const fs::path record = run_dir / "run.yaml";
    if (!fs::exists(record)) {
        throw params::ConfigError(record.string() +
                                  ": missing (not a run directory of this maptune version; give --experiment)");
    }
    const YAML::Node root = params::load_yaml_file(record.string());
    const params::YamlPath where{record.string(), ""};
    if (!root["experiment_file"].IsDefined()) where.fail(root, "missing key 'experiment_file'");
    const std::string file = params::read_string(root["experiment_file"], where.child("experiment_file"));
    if (file.empty() || !fs::exists(file)) {
        where.child("experiment_file").fail(root["experiment_file"],
                                            "experiment '" + file + "' is not there any more; give --experiment");
    }
    return file;
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

std::string run_store_path(const fs::path& run_dir) {
    for (const fs::path& p : {run_dir / "observations.db", run_dir.parent_path() / "observations.db"}) {
        if (fs::exists(p)) return p.string();
    }
    return "";
}

}  // namespace maptune::experiment
