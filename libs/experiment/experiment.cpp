#include "experiment/experiment.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "gp/cholesky.hpp"
#include "params/yaml_util.hpp"

namespace maptune::experiment {
namespace {

namespace fs = std::filesystem;
using params::YamlPath;

std::string resolve(const fs::path& base, const std::string& p) {
    const fs::path path(p);
    return path.is_absolute() ? p : (base / path).lexically_normal().string();
}

int read_int(const YAML::Node& n, const YamlPath& where, int low, int high) {
    const double v = params::read_finite_double(n, where);
    if (v != static_cast<double>(static_cast<long long>(v)) || v < low || v > high) {
        where.fail(n, "expected an integer in [" + std::to_string(low) + ", " +
                          std::to_string(high) + "], got " + n.Scalar());
    }
    return static_cast<int>(v);
}

double read_range(const YAML::Node& n, const YamlPath& where, double low, double high) {
    const double v = params::read_finite_double(n, where);
    if (v < low || v > high) {
        where.fail(n, "expected a number in [" + params::format_double(low) + ", " +
                          params::format_double(high) + "], got " + n.Scalar());
    }
    return v;
}

std::string read_choice(const YAML::Node& n, const YamlPath& where,
                        std::initializer_list<const char*> choices) {
    const std::string v = params::read_string(n, where);
    std::string all;
    for (const char* c : choices) {
        if (v == c) return v;
        all += all.empty() ? c : std::string(" | ") + c;
    }
    where.fail(n, "expected one of " + all + ", got '" + v + "'");
}

struct DatasetSection {
    std::string dir;
    std::optional<GenerateSpec> generate;
};

// dataset: a directory, or {dir, generate: {preset, runs, submaps, seed, sim: {KEY: VALUE}}}.
DatasetSection read_dataset_section(const YAML::Node& n, const YamlPath& p, const fs::path& base) {
    DatasetSection out;
    if (n.IsScalar()) {
        out.dir = resolve(base, n.Scalar());
        return out;
    }
    params::check_keys(n, p, {"dir", "generate"});
    if (!n["dir"].IsDefined()) p.fail(n, "missing key 'dir'");
    out.dir = resolve(base, params::read_string(n["dir"], p.child("dir")));
    if (n["generate"].IsDefined()) {
        const YamlPath g = p.child("generate");
        const YAML::Node gn = n["generate"];
        params::check_keys(gn, g, {"preset", "runs", "submaps", "seed", "sim"});
        if (!gn["preset"].IsDefined()) g.fail(gn, "missing key 'preset'");
        GenerateSpec spec;
        spec.preset = read_choice(gn["preset"], g.child("preset"), {"lab", "moon", "lab-tiny", "moon-tiny"});
        if (gn["runs"].IsDefined()) spec.runs = read_int(gn["runs"], g.child("runs"), 1, 1000);
        if (gn["submaps"].IsDefined()) spec.submaps = read_int(gn["submaps"], g.child("submaps"), 2, 10000);
        if (gn["seed"].IsDefined()) {
            spec.seed = static_cast<std::uint64_t>(read_int(gn["seed"], g.child("seed"), 0, 1 << 30));
        }
        if (const YAML::Node sn = gn["sim"]; sn.IsDefined()) {
            // Names and ranges are checked where the dataset is made (SimConfig lives there).
            const YamlPath sp = g.child("sim");
            params::check_unique_keys(sn, sp);
            for (const auto& kv : sn) {
                const std::string key = kv.first.as<std::string>();
                if (!kv.second.IsScalar()) sp.child(key).fail(kv.second, "expected a number");
                spec.sim.push_back({key, kv.second.Scalar(), sp.child(key).where(kv.second)});
            }
        }
        out.generate = spec;
    }
    return out;
}

// validate: a list of {label, dataset, view, reference, m_star | m_star_per_pair}.
std::vector<ValidationTarget> read_validate_section(const YAML::Node& n, const YamlPath& p,
                                                    const fs::path& base) {
    if (!n.IsSequence()) p.fail(n, "expected a list of held-out targets ({dataset, view, reference, m_star})");
    std::vector<ValidationTarget> out;
    std::set<std::string> labels;
    for (std::size_t i = 0; i < n.size(); ++i) {
        const YAML::Node t = n[i];
        const YamlPath tp = p.index(i);
        if (!t.IsMap()) tp.fail(t, "expected a map with at least 'dataset'");
        params::check_keys(t, tp, {"label", "dataset", "view", "reference", "m_star", "m_star_per_pair"});
        if (!t["dataset"].IsDefined()) tp.fail(t, "missing key 'dataset'");
        ValidationTarget v;
        DatasetSection d = read_dataset_section(t["dataset"], tp.child("dataset"), base);
        v.dataset_dir = d.dir;
        v.generate = d.generate;
        v.label = t["label"].IsDefined() ? params::read_string(t["label"], tp.child("label"))
                                         : fs::path(v.dataset_dir).filename().string();
        if (v.label.empty() || v.label.find_first_of(",\n") != std::string::npos) {
            tp.child("label").fail(t["label"], "expected a non-empty label without ',' or newline");
        }
        if (v.label == kPooledValidationLabel) {
            tp.child("label").fail(t["label"], "'" + v.label + "' is reserved for the column of all targets together");
        }
        if (!labels.insert(v.label).second) {
            tp.fail(t, "label '" + v.label + "' used twice (give each target its own 'label')");
        }
        if (t["view"].IsDefined()) v.view = read_choice(t["view"], tp.child("view"), {"complete", "subsequent"});
        if (t["reference"].IsDefined()) {
            v.reference = read_choice(t["reference"], tp.child("reference"), {"gt", "odometry"});
        }
        if (t["m_star"].IsDefined() && t["m_star_per_pair"].IsDefined()) {
            tp.fail(t, "give m_star or m_star_per_pair, not both");
        }
        if (t["m_star"].IsDefined() && !(t["m_star"].IsScalar() && t["m_star"].Scalar() == "auto")) {
            v.m_star = read_range(t["m_star"], tp.child("m_star"), 1e-9, 1e9);
        }
        if (t["m_star_per_pair"].IsDefined()) {
            v.m_star_per_pair = read_range(t["m_star_per_pair"], tp.child("m_star_per_pair"), 1e-9, 1e9);
        }
        out.push_back(std::move(v));
    }
    return out;
}

}  // namespace

Experiment load_experiment(const std::string& file) {
    const YAML::Node root = params::load_yaml_file(file);
    const fs::path base = fs::path(file).parent_path();
    const YamlPath top{file, ""};
    params::check_keys(root, top,
                       {"name", "description", "space", "optimize", "fixed", "dataset", "view",
                        "reference", "measure", "budget", "optimizer", "start_points", "matcher",
                        "workers", "seeds", "validate", "objective", "fidelity"});
    Experiment e;
    e.file = file;
    const bool black_box = root["objective"].IsDefined();
    for (const char* required : {"name", "space", "dataset"}) {
        if (black_box && std::string(required) == "dataset") continue;
        if (!root[required].IsDefined()) top.fail(root, std::string("missing key '") + required + "'");
    }
    if (black_box) {
        for (const char* key : {"dataset", "view", "reference", "measure", "matcher", "validate", "workers", "fidelity"}) {
            if (root[key].IsDefined()) {
                top.child(key).fail(root[key], "does not apply to a black-box experiment (one with 'objective')");
            }
        }
        const YamlPath p = top.child("objective");
        const YAML::Node n = root["objective"];
        params::require_map(n, p);
        params::check_keys(n, p, {"command", "direction", "timeout_s", "parallel"});
        if (!n["command"].IsDefined()) p.fail(n, "missing key 'command'");
        Experiment::Objective o;
        o.command = params::read_string(n["command"], p.child("command"));
        if (o.command.find_first_not_of(" \t") == std::string::npos) p.child("command").fail(n["command"], "empty command");
        if (n["direction"].IsDefined()) {
            e.minimize = read_choice(n["direction"], p.child("direction"), {"maximize", "minimize"}) == "minimize";
        }
        if (n["timeout_s"].IsDefined()) o.timeout_s = read_range(n["timeout_s"], p.child("timeout_s"), 0, 1e7);
        if (n["parallel"].IsDefined()) o.parallel = read_int(n["parallel"], p.child("parallel"), 1, 256);
        e.objective = o;
    }
    e.name = params::read_string(root["name"], top.child("name"));
    e.space_file = resolve(base, params::read_string(root["space"], top.child("space")));
    try {
        e.space = params::ParameterSpace::load(e.space_file);
    } catch (const params::ConfigError& err) {
        top.child("space").fail(root["space"], err.what());
    }

    // optimize: list of names (default: all, in space order).
    std::set<std::string> chosen;
    if (root["optimize"].IsDefined()) {
        const YamlPath p = top.child("optimize");
        if (!root["optimize"].IsSequence()) p.fail(root["optimize"], "expected a list of parameter names");
        for (std::size_t i = 0; i < root["optimize"].size(); ++i) {
            const YAML::Node n = root["optimize"][i];
            const std::string name = params::read_string(n, p.index(i));
            if (e.space.find(name) == nullptr) {
                p.index(i).fail(n, "unknown parameter '" + name + "' of space '" + e.space.name() + "'");
            }
            if (!chosen.insert(name).second) p.index(i).fail(n, "'" + name + "' listed twice");
        }
        if (chosen.empty()) p.fail(root["optimize"], "expected at least one parameter");
    }
    for (const auto& s : e.space.specs()) {
        if (chosen.empty() || chosen.count(s.name)) e.optimize.push_back(s.name);
    }

    // fixed: overrides of the defaults for non-optimized parameters.
    e.fixed = e.space.defaults();
    if (root["fixed"].IsDefined()) {
        const YamlPath p = top.child("fixed");
        params::check_unique_keys(root["fixed"], p);
        for (const auto& kv : root["fixed"]) {
            const std::string name = kv.first.as<std::string>();
            const params::ParameterSpec* spec = e.space.find(name);
            if (spec == nullptr) p.child(name).fail(kv.first, "unknown parameter");
            if (std::find(e.optimize.begin(), e.optimize.end(), name) != e.optimize.end()) {
                p.child(name).fail(kv.first, "is optimized; fix it or optimize it, not both");
            }
            params::ParameterSet one{{name, params::read_finite_double(kv.second, p.child(name))}};
            try {
                e.space.complete(one);
            } catch (const params::ConfigError& err) {
                p.child(name).fail(kv.second, err.what());
            }
            e.fixed.set(name, one.get(name));
        }
    }

    if (!black_box) {
        DatasetSection d = read_dataset_section(root["dataset"], top.child("dataset"), base);
        e.dataset_dir = d.dir;
        e.generate = d.generate;
    }
    if (root["view"].IsDefined()) {
        e.view = read_choice(root["view"], top.child("view"), {"complete", "subsequent"});
    }
    if (root["reference"].IsDefined()) {
        e.reference = read_choice(root["reference"], top.child("reference"), {"gt", "odometry"});
    }
    if (root["measure"].IsDefined()) {
        const YamlPath p = top.child("measure");
        const YAML::Node n = root["measure"];
        params::check_keys(n, p, {"e_star", "m_star", "m_star_per_pair", "w_v", "max_pair_seconds"});
        if (n["e_star"].IsDefined()) e.e_star = read_range(n["e_star"], p.child("e_star"), 0.051, 1e6);
        if (n["m_star"].IsDefined() && !(n["m_star"].IsScalar() && n["m_star"].Scalar() == "auto")) {
            e.m_star = read_range(n["m_star"], p.child("m_star"), 1e-9, 1e9);
        }
        if (n["m_star_per_pair"].IsDefined()) {
            if (n["m_star"].IsDefined()) {
                p.child("m_star_per_pair").fail(n["m_star_per_pair"], "give either 'm_star' or 'm_star_per_pair', not both");
            }
            e.m_star_per_pair = read_range(n["m_star_per_pair"], p.child("m_star_per_pair"), 1e-9, 1e6);
        }
        if (n["w_v"].IsDefined()) e.w_v = read_range(n["w_v"], p.child("w_v"), 0, 1);
        if (n["max_pair_seconds"].IsDefined()) {
            e.max_pair_seconds = read_range(n["max_pair_seconds"], p.child("max_pair_seconds"), 1e-6, 1e6);
        }
    }
    if (root["fidelity"].IsDefined()) {
        const YamlPath p = top.child("fidelity");
        const YAML::Node n = root["fidelity"];
        params::require_map(n, p);
        params::check_keys(n, p, {"subset", "z"});
        if (!n["subset"].IsDefined()) p.fail(n, "missing key 'subset' (k: first evaluate on about 1/k of the pairs)");
        e.fidelity_subset = read_int(n["subset"], p.child("subset"), 2, 1000000);
        if (n["z"].IsDefined()) e.fidelity_z = read_range(n["z"], p.child("z"), 0, 10);
    }
    if (root["budget"].IsDefined()) {
        const YamlPath p = top.child("budget");
        const YAML::Node n = root["budget"];
        params::check_keys(n, p, {"evaluations", "seconds"});
        if (n["evaluations"].IsDefined()) {
            e.max_evaluations = read_int(n["evaluations"], p.child("evaluations"), 1, 100000);
        }
        if (n["seconds"].IsDefined()) e.max_seconds = read_range(n["seconds"], p.child("seconds"), 0, 1e9);
    }
    if (root["optimizer"].IsDefined()) {
        const YamlPath p = top.child("optimizer");
        const YAML::Node n = root["optimizer"];
        params::check_keys(n, p, {"acquisition", "ucb_kappa", "initial_points", "seed", "batch", "warping", "search",
                                  "quadratic_steps", "hyper_samples", "cholesky", "dead_regions"});
        if (n["dead_regions"].IsDefined()) e.dead_regions = params::read_bool(n["dead_regions"], p.child("dead_regions"));
        if (n["warping"].IsDefined()) {
            e.warping = read_choice(n["warping"], p.child("warping"), {"none", "log", "copula", "automatic"});
        }
        if (n["search"].IsDefined()) {
            e.search = read_choice(n["search"], p.child("search"), {"global", "trust_region", "alternate"});
        }
        if (n["quadratic_steps"].IsDefined()) {
            e.quadratic_steps = params::read_bool(n["quadratic_steps"], p.child("quadratic_steps"));
        }
        if (n["hyper_samples"].IsDefined()) {
            e.hyper_samples = read_int(n["hyper_samples"], p.child("hyper_samples"), 0, 64);
        }
        if (n["cholesky"].IsDefined()) {
            e.cholesky = read_choice(n["cholesky"], p.child("cholesky"), {"eigen", "cholmod"});
            if (e.cholesky == "cholmod" && !gp::cholmod_available()) {
                p.child("cholesky").fail(n["cholesky"], "this build has no CHOLMOD (SuiteSparse not found at build time)");
            }
        }
        if (n["acquisition"].IsDefined()) {
            e.acquisition = read_choice(n["acquisition"], p.child("acquisition"),
                                        {"ucb", "ucb_schedule", "ei", "log_ei"});
        }
        if (n["ucb_kappa"].IsDefined()) e.ucb_kappa = read_range(n["ucb_kappa"], p.child("ucb_kappa"), 0, 100);
        if (n["initial_points"].IsDefined()) {
            e.initial_points = read_int(n["initial_points"], p.child("initial_points"), 0, 10000);
        }
        if (n["seed"].IsDefined()) {
            e.seed = static_cast<std::uint64_t>(read_int(n["seed"], p.child("seed"), 0, 1 << 30));
        }
        if (n["batch"].IsDefined()) e.batch = read_int(n["batch"], p.child("batch"), 0, 1024);
    }
    if (root["start_points"].IsDefined()) {
        const YamlPath p = top.child("start_points");
        if (!root["start_points"].IsSequence()) p.fail(root["start_points"], "expected a list of parameter files");
        for (std::size_t i = 0; i < root["start_points"].size(); ++i) {
            const YAML::Node n = root["start_points"][i];
            const std::string f = resolve(base, params::read_string(n, p.index(i)));
            try {
                params::ParameterSet s = params::load_parameter_set(f, e.space);
                // Fixed parameters keep their fixed value whatever the start file says.
                for (const auto& [name, value] : e.fixed) {
                    if (std::find(e.optimize.begin(), e.optimize.end(), name) == e.optimize.end()) {
                        s.set(name, value);
                    }
                }
                e.start_points.push_back(s);
                e.start_point_files.push_back(f);
            } catch (const params::ConfigError& err) {
                p.index(i).fail(n, err.what());
            }
        }
    }
    if (root["matcher"].IsDefined()) {
        const YamlPath p = top.child("matcher");
        const YAML::Node n = root["matcher"];
        params::check_keys(n, p, {"id", "threads", "feature_cache_mb", "neighbour_cache_mb", "pair_time_limit_s", "total_time_limit_s", "settings"});
        if (n["id"].IsDefined()) {
            e.matcher_id = params::read_string(n["id"], p.child("id"));
            if (e.matcher_id.empty() || e.matcher_id.find_first_of(" \t/") != std::string::npos)
                p.child("id").fail(n["id"], "expected a matcher id without spaces or '/' (e.g. lru_matcher)");
            if (e.matcher_id != "lru_matcher" && n["settings"].IsDefined())
                p.child("settings").fail(n["settings"], "settings apply to the reference matcher (lru_matcher) only, not to '" +
                                                            e.matcher_id + "'");
        }
        if (n["settings"].IsDefined()) {
            const YamlPath sp = p.child("settings");
            params::require_map(n["settings"], sp);
            params::check_unique_keys(n["settings"], sp);
            for (const auto& kv : n["settings"]) {
                if (!kv.first.IsScalar()) sp.fail(kv.first, "expected a setting name as key");
                const std::string key = kv.first.as<std::string>();
                const YamlPath kp = sp.child(key);
                if (!kv.second.IsScalar()) kp.fail(kv.second, "expected a value (number, true/false or a name)");
                e.matcher_settings.push_back({key, kv.second.as<std::string>(), kp.where(kv.second)});
            }
        }
        if (n["threads"].IsDefined()) e.matcher_threads = read_int(n["threads"], p.child("threads"), 0, 256);
        if (n["feature_cache_mb"].IsDefined()) {
            e.feature_cache_mb = read_int(n["feature_cache_mb"], p.child("feature_cache_mb"), 64, 1 << 20);
        }
        if (n["neighbour_cache_mb"].IsDefined()) {
            e.neighbour_cache_mb = read_int(n["neighbour_cache_mb"], p.child("neighbour_cache_mb"), 0, 1 << 20);
        }
        if (n["pair_time_limit_s"].IsDefined()) {
            e.pair_time_limit_s = read_range(n["pair_time_limit_s"], p.child("pair_time_limit_s"), 0.01, 1e6);
        }
        if (n["total_time_limit_s"].IsDefined()) {
            e.total_time_limit_s = read_range(n["total_time_limit_s"], p.child("total_time_limit_s"), 0.01, 1e7);
        }
    }
    if (root["seeds"].IsDefined()) {
        const YamlPath p = top.child("seeds");
        const YAML::Node n = root["seeds"];
        if (!n.IsSequence() || n.size() == 0) p.fail(n, "expected a non-empty list of optimizer seeds, e.g. [1, 2, 3]");
        std::set<std::uint64_t> seen;
        for (std::size_t i = 0; i < n.size(); ++i) {
            const auto seed = static_cast<std::uint64_t>(read_int(n[i], p.index(i), 0, 1 << 30));
            if (!seen.insert(seed).second) p.index(i).fail(n[i], "seed " + std::to_string(seed) + " listed twice");
            e.seeds.push_back(seed);
        }
    }
    if (root["validate"].IsDefined()) e.validate = read_validate_section(root["validate"], top.child("validate"), base);
    if (root["workers"].IsDefined()) e.workers = read_int(root["workers"], top.child("workers"), 1, 64);
    return e;
}

double objective(const Experiment& e, double p, double pair_s) {
    if (e.max_pair_seconds <= 0 || pair_s <= e.max_pair_seconds) return p;
    const double ratio = e.max_pair_seconds / pair_s;
    return p * ratio * ratio;
}

std::vector<bo::ParameterSpec> search_space(const Experiment& e) {
    std::vector<bo::ParameterSpec> out;
    for (const auto& name : e.optimize) {
        const params::ParameterSpec& s = *e.space.find(name);
        const bool is_int = s.type == params::ParamType::kInt;
        // Floats are evaluated at `decimals`: proposing between those values would only
        // repeat an evaluation under another name.
        out.push_back({s.name, s.low, s.high, is_int, s.log_scale, is_int ? 0.0 : std::pow(10.0, -s.decimals)});
    }
    return out;
}

params::ParameterSet full_set(const Experiment& e, const std::vector<double>& values) {
    params::ParameterSet set = e.fixed;
    for (std::size_t i = 0; i < e.optimize.size() && i < values.size(); ++i) {
        set.set(e.optimize[i], values[i]);
    }
    return set;
}

std::vector<double> optimizer_values(const Experiment& e, const params::ParameterSet& set) {
    std::vector<double> out;
    for (const auto& name : e.optimize) out.push_back(set.get(name));
    return out;
}

bo::OptimizerOptions optimizer_options(const Experiment& e) {
    bo::OptimizerOptions o;
    o.direction = e.minimize ? bo::Direction::minimize : bo::Direction::maximize;
    o.acquisition = *bo::acquisition_from_string(e.acquisition);  // validated on load
    o.ucb_kappa = e.ucb_kappa;
    o.initial_points = e.initial_points;
    o.seed = e.seed;
    o.warping = e.warping == "none"     ? bo::OutputWarping::none
                : e.warping == "log"    ? bo::OutputWarping::log
                : e.warping == "copula" ? bo::OutputWarping::copula
                                        : bo::OutputWarping::automatic;
    o.search = e.search == "global"         ? bo::SearchRegion::global
               : e.search == "trust_region" ? bo::SearchRegion::trust_region
                                            : bo::SearchRegion::alternate;
    o.quadratic_steps = e.quadratic_steps;
    o.hyper_samples = e.hyper_samples;
    o.gp.backend = e.cholesky == "cholmod" ? gp::CholeskyBackend::cholmod : gp::CholeskyBackend::eigen;
    // The matcher's p = 0 is "no match at all": whole regions of the space are dead (issue 15).
    if (!e.objective && e.dead_regions) o.dead_value = 0.0;
    return o;
}

}  // namespace maptune::experiment
