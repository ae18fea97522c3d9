#include "evaluation/compare.hpp"

#include <cmath>
#include <limits>

#include "params/yaml_util.hpp"

namespace maptune::evaluation {
namespace fs = std::filesystem;
using params::ConfigError;
using params::YamlPath;

CompareTarget parse_compare_target(const std::string& spec) {
    CompareTarget t;
    std::string rest = spec;
    if (const auto eq = rest.find('='); eq != std::string::npos) {
        t.label = rest.substr(0, eq);
        rest = rest.substr(eq + 1);
        if (t.label.empty()) throw ConfigError("target '" + spec + "': empty label before '='");
    }
    // Split at the last two colons only when they name a view / reference, so dataset paths
    // may contain colons.
    std::vector<std::string> tail;
    for (int i = 0; i < 2; ++i) {
        const auto colon = rest.rfind(':');
        if (colon == std::string::npos) break;
        tail.insert(tail.begin(), rest.substr(colon + 1));
        rest = rest.substr(0, colon);
    }
    if (rest.empty()) throw ConfigError("target '" + spec + "': no dataset directory");
    t.dataset = rest;
    try {
        if (!tail.empty()) t.view = dataset::parse_view(tail[0]);
        if (tail.size() > 1) t.reference = dataset::parse_reference(tail[1]);
    } catch (const std::exception& e) {
        throw ConfigError("target '" + spec + "': " + e.what() +
                          " (expected [LABEL=]DATASET[:complete|subsequent[:gt|odometry]])");
    }
    if (t.label.empty()) t.label = fs::path(t.dataset).lexically_normal().filename().string();
    if (t.label.empty()) t.label = fs::path(t.dataset).lexically_normal().parent_path().filename().string();
    return t;
}

namespace {

double positive(const YAML::Node& node, const YamlPath& where) {
    const double v = params::read_finite_double(node, where);
    if (v <= 0) where.fail(node, "expected a number > 0, got " + node.Scalar());
    return v;
}

std::vector<std::string> read_string_list(const YAML::Node& node, const YamlPath& where) {
    if (!node.IsSequence()) where.fail(node, "expected a list");
    std::vector<std::string> out;
    for (std::size_t i = 0; i < node.size(); ++i) out.push_back(params::read_string(node[i], where.index(i)));
    return out;
}

std::string resolve(const fs::path& base, const std::string& p) {
    return fs::path(p).is_absolute() ? p : (base / p).lexically_normal().string();
}

}  // namespace

CompareConfig load_compare_config(const std::string& file) {
    const YAML::Node root = params::load_yaml_file(file);
    const YamlPath at{file, ""};
    params::require_map(root, at);
    params::check_keys(root, at, {"name", "description", "params", "on", "e_star", "w_v", "reference"});
    const fs::path base = fs::path(file).parent_path();
    CompareConfig c;
    if (root["params"]) {
        for (const auto& p : read_string_list(root["params"], at.child("params"))) c.params.push_back(resolve(base, p));
    }
    if (root["on"]) {
        const auto specs = read_string_list(root["on"], at.child("on"));
        for (std::size_t i = 0; i < specs.size(); ++i) {
            try {
                auto t = parse_compare_target(specs[i]);
                t.dataset = resolve(base, t.dataset.string());
                c.targets.push_back(std::move(t));
            } catch (const ConfigError& e) {
                at.child("on").index(i).fail(root["on"][i], e.what());
            }
        }
    }
    if (root["e_star"]) c.e_star = positive(root["e_star"], at.child("e_star"));
    if (root["w_v"]) {
        c.w_v = params::read_finite_double(root["w_v"], at.child("w_v"));
        if (*c.w_v < 0 || *c.w_v > 1) at.child("w_v").fail(root["w_v"], "expected 0..1");
    }
    if (const YAML::Node ref = root["reference"]) {
        const YamlPath rat = at.child("reference");
        params::require_map(ref, rat);
        params::check_unique_keys(ref, rat);
        for (const auto& kv : ref) {
            ReferenceColumn col;
            col.name = params::read_string(kv.first, rat);
            const YamlPath cat = rat.child(col.name);
            params::require_map(kv.second, cat);
            params::check_keys(kv.second, cat, {"aliases", "m_star_per_pair", "scores", "note"});
            if (kv.second["aliases"]) col.aliases = read_string_list(kv.second["aliases"], cat.child("aliases"));
            if (kv.second["m_star_per_pair"]) {
                col.m_star_per_pair = positive(kv.second["m_star_per_pair"], cat.child("m_star_per_pair"));
            }
            const YAML::Node scores = kv.second["scores"];
            if (!scores) cat.fail(kv.second, "missing key 'scores' (set name: p)");
            params::require_map(scores, cat.child("scores"));
            params::check_unique_keys(scores, cat.child("scores"));
            for (const auto& s : scores) {
                const std::string set = params::read_string(s.first, cat.child("scores"));
                const double p = params::read_finite_double(s.second, cat.child("scores").child(set));
                if (p < 0 || p >= 1) cat.child("scores").child(set).fail(s.second, "expected p in [0, 1)");
                col.scores[set] = p;
            }
            c.reference.push_back(std::move(col));
        }
    }
    return c;
}

const ReferenceColumn* find_reference_column(const std::vector<ReferenceColumn>& columns,
                                             const std::string& label, const std::string& world) {
    for (const auto& c : columns) {
        if (c.name == label) return &c;
    }
    for (const std::string& key : {label, world}) {
        if (key.empty()) continue;
        for (const auto& c : columns) {
            if (c.name == key) return &c;
            for (const auto& a : c.aliases) {
                if (a == key) return &c;
            }
        }
    }
    return nullptr;
}

double kendall_tau_b(const std::vector<double>& x, const std::vector<double>& y) {
    const std::size_t n = x.size();
    if (n != y.size()) throw std::invalid_argument("kendall_tau_b: lists of different length");
    // O(n^2) is fine for tables of parameter sets.
    double concordant_minus_discordant = 0, not_tied_x = 0, not_tied_y = 0;
    for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t j = i + 1; j < n; ++j) {
            const double dx = x[i] - x[j], dy = y[i] - y[j];
            const int sx = (dx > 0) - (dx < 0), sy = (dy > 0) - (dy < 0);
            concordant_minus_discordant += sx * sy;
            not_tied_x += sx != 0;
            not_tied_y += sy != 0;
        }
    }
    if (not_tied_x == 0 || not_tied_y == 0) return std::numeric_limits<double>::quiet_NaN();
    return concordant_minus_discordant / std::sqrt(not_tied_x * not_tied_y);
}

CompareResult compare(const params::ParameterSpace& space, const std::vector<NamedParameterSet>& sets,
                      const std::vector<CompareTarget>& targets, const CompareOptions& options) {
    if (sets.empty()) throw ConfigError("compare: no parameter sets");
    if (targets.empty()) throw ConfigError("compare: no dataset views (--on)");
    CompareResult result;
    for (const auto& s : sets) result.set_names.push_back(s.name);

    // Open and check every target first, so a typo fails before hours of matching.
    struct Opened {
        dataset::Dataset ds;
        std::vector<dataset::SubmapPair> pairs;
        const ReferenceColumn* reference;  // null: no reference scores for this view
    };
    std::vector<Opened> opened;
    for (const auto& t : targets) {
        CompareColumn col;
        col.target = t;
        dataset::Dataset ds = [&] {
            try {
                return dataset::Dataset::open(t.dataset);
            } catch (const std::exception& e) {
                throw ConfigError("target '" + t.label + "': " + e.what());
            }
        }();
        col.dataset_name = ds.manifest().name;
        col.dataset_id = ds.manifest().id;
        if (auto it = ds.manifest().meta.find("world"); it != ds.manifest().meta.end()) col.world = it->second;
        auto pairs = ds.pairs(t.view, t.reference);
        col.pairs = pairs.size();
        const ReferenceColumn* ref = find_reference_column(options.reference, t.label, col.world);
        if (ref) col.reference_column = ref->name;
        col.settings.e_star = options.e_star;
        col.settings.w_v = options.w_v;
        if (t.m_star) {
            col.settings.m_star = *t.m_star;
            col.m_star_rule = "given";
        } else if (t.m_star_per_pair || (ref && ref->m_star_per_pair)) {
            const double f = t.m_star_per_pair ? *t.m_star_per_pair : *ref->m_star_per_pair;
            col.settings.m_star = std::max(1.0, f * static_cast<double>(pairs.size()));
            col.m_star_rule = params::format_double(f) + " x " + std::to_string(pairs.size()) + " pairs" +
                              (t.m_star_per_pair ? "" : " (reference " + ref->name + ")");
        } else {
            col.settings.m_star = scoring::derive_m_star(ds.reference_overlaps(pairs, t.reference));
            col.m_star_rule = std::string("pairs with ") + dataset::to_string(t.reference) + " overlap >= 0.3";
        }
        if (auto bad = measure::check_settings(col.settings); !bad.empty()) {
            throw ConfigError("target '" + t.label + "': " + bad);
        }
        result.columns.push_back(std::move(col));
        opened.push_back({std::move(ds), std::move(pairs), ref});
    }

    const std::size_t total = sets.size() * targets.size();
    std::size_t done = 0;
    for (std::size_t c = 0; c < targets.size(); ++c) {
        CompareColumn& col = result.columns[c];
        Evaluator evaluator(opened[c].ds, space, options.matcher);  // features shared across sets
        const ReferenceColumn* ref = opened[c].reference;
        std::vector<double> ours, theirs;
        for (const auto& s : sets) {
            if (options.progress) {
                options.progress(col.target.label + ": " + s.name + " (" + std::to_string(++done) + "/" +
                                 std::to_string(total) + ")");
            }
            CompareCell cell;
            const auto obs = evaluator.evaluate_cached(options.db, col.target.view, s.set, &cell.from_store);
            cell.wall_seconds = cell.from_store ? 0.0 : obs.wall_seconds;
            cell.report = scoring::score_observation(opened[c].ds, opened[c].pairs, obs.pairs, col.settings);
            if (ref) {
                if (auto it = ref->scores.find(s.name); it != ref->scores.end()) {
                    cell.reference_p = it->second;
                    ours.push_back(cell.report.score.p);
                    theirs.push_back(it->second);
                }
            }
            col.cells.push_back(std::move(cell));
        }
        if (ref) col.tau = kendall_tau_b(ours, theirs);
    }
    return result;
}

}  // namespace maptune::evaluation
