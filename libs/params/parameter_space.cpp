#include "params/parameter_space.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <set>

#include "params/parameter_set.hpp"
#include "params/yaml_util.hpp"

namespace maptune::params {
namespace {

bool is_integral(double v) { return std::isfinite(v) && v == std::floor(v); }

std::string type_name(ParamType t) { return t == ParamType::kInt ? "int" : "float"; }

// What is wrong with `value` for `spec`, or "" when it is valid.
std::string value_problem(const ParameterSpec& spec, double value) {
    if (!std::isfinite(value)) return spec.name + ": value is not a finite number";
    if (spec.type == ParamType::kInt && !is_integral(value)) {
        return spec.name + ": expected an integer, got " + format_double(value);
    }
    if (value < spec.low || value > spec.high) {
        return spec.name + ": " + format_double(value) + " is outside [" +
               format_double(spec.low) + ", " + format_double(spec.high) + "]";
    }
    return "";
}

// Rounding works on value x 10^decimals as a 64-bit integer: beyond that, different values
// would share one key (and 1e300 would round to a negative number). "" when the bounds fit.
std::string rounding_problem(const ParameterSpec& s) {
    const int decimals = s.type == ParamType::kInt ? 0 : s.decimals;
    if (std::max(std::fabs(s.low), std::fabs(s.high)) * std::pow(10.0, decimals) <= 1e18) return "";
    return "bounds [" + format_double(s.low) + ", " + format_double(s.high) + "] too large to round to " +
           std::to_string(decimals) + " decimals (|bound| x 10^decimals must stay within 1e18)";
}

ParameterSpace parse_space(const YAML::Node& root, const std::string& source) {
    const YamlPath top{source, ""};
    check_keys(root, top, {"name", "description", "parameters"});
    const std::string name = read_string(root["name"], top.child("name"));
    const YamlPath params_path = top.child("parameters");
    const YAML::Node params = root["parameters"];
    if (!params.IsDefined()) top.fail(root, "missing key 'parameters'");
    check_unique_keys(params, params_path);

    std::vector<ParameterSpec> specs;
    for (const auto& kv : params) {
        ParameterSpec s;
        s.name = kv.first.as<std::string>();
        const YamlPath p = params_path.child(s.name);
        const YAML::Node& n = kv.second;
        check_keys(n, p, {"type", "low", "high", "default", "unit", "description", "log_scale", "decimals"});
        for (const char* required : {"type", "low", "high", "default"}) {
            if (!n[required].IsDefined()) p.fail(n, std::string("missing key '") + required + "'");
        }
        const std::string type = read_string(n["type"], p.child("type"));
        if (type == "float") {
            s.type = ParamType::kFloat;
        } else if (type == "int") {
            s.type = ParamType::kInt;
        } else {
            p.child("type").fail(n["type"], "expected 'float' or 'int', got '" + type + "'");
        }
        s.low = read_finite_double(n["low"], p.child("low"));
        s.high = read_finite_double(n["high"], p.child("high"));
        s.default_value = read_finite_double(n["default"], p.child("default"));
        if (n["unit"].IsDefined()) s.unit = read_string(n["unit"], p.child("unit"));
        if (n["description"].IsDefined()) {
            s.description = read_string(n["description"], p.child("description"));
        }
        if (n["log_scale"].IsDefined()) s.log_scale = read_bool(n["log_scale"], p.child("log_scale"));
        if (n["decimals"].IsDefined()) {
            const double d = read_finite_double(n["decimals"], p.child("decimals"));
            if (!is_integral(d) || d < 0 || d > 12) p.child("decimals").fail(n["decimals"], "expected an integer in 0..12");
            if (s.type == ParamType::kInt) p.child("decimals").fail(n["decimals"], "only for float parameters");
            s.decimals = static_cast<int>(d);
        }
        if (const std::string problem = rounding_problem(s); !problem.empty()) {
            if (n["decimals"].IsDefined()) {
                p.child("decimals").fail(n["decimals"], "too many decimals for bounds this large");
            }
            p.fail(n, problem);
        }
        if (s.low > s.high) {
            p.fail(n, "low " + format_double(s.low) + " > high " + format_double(s.high));
        }
        if (s.type == ParamType::kInt) {
            if (!is_integral(s.low)) p.child("low").fail(n["low"], "expected an integer");
            if (!is_integral(s.high)) p.child("high").fail(n["high"], "expected an integer");
        }
        if (s.log_scale && s.low <= 0) p.child("log_scale").fail(n["log_scale"], "needs low > 0");
        const std::string problem = value_problem(s, s.default_value);
        if (!problem.empty()) p.child("default").fail(n["default"], problem);
        specs.push_back(std::move(s));
    }
    return ParameterSpace(name, std::move(specs));
}

}  // namespace

std::string format_fixed(double value, int decimals) {
    // Integer arithmetic after one rounding step, so the text never depends on printf's
    // locale or on platform-specific rounding of the last digit.
    double scale = 1;
    for (int i = 0; i < decimals; ++i) scale *= 10;
    const long long scaled = std::llround(value * scale);
    const bool negative = scaled < 0;
    const unsigned long long mag = negative ? 0ULL - static_cast<unsigned long long>(scaled)
                                            : static_cast<unsigned long long>(scaled);
    const auto unit = static_cast<unsigned long long>(scale);
    std::string text = (negative ? "-" : "") + std::to_string(mag / unit);
    if (decimals > 0) {
        std::string frac = std::to_string(mag % unit);
        text += "." + std::string(static_cast<std::size_t>(decimals) - frac.size(), '0') + frac;
    }
    return text;
}

std::string format_double(double value) {
    if (std::isnan(value)) return ".nan";
    if (std::isinf(value)) return value > 0 ? ".inf" : "-.inf";
    char buf[64];
    const auto res = std::to_chars(buf, buf + sizeof(buf), value);
    std::string text(buf, res.ptr);
    const auto e = text.find_first_of("eE");
    const std::string mantissa = text.substr(0, e);
    if (mantissa.find('.') == std::string::npos) {
        text.insert(e == std::string::npos ? text.size() : e, ".0");
    }
    return text;
}

ParameterSpace::ParameterSpace(std::string name, std::vector<ParameterSpec> specs)
    : name_(std::move(name)), specs_(std::move(specs)) {
    std::set<std::string> names;
    for (const auto& s : specs_) {
        if (s.name.empty()) throw ConfigError("parameter with an empty name");
        if (!names.insert(s.name).second) throw ConfigError(s.name + ": duplicate parameter");
        if (!std::isfinite(s.low) || !std::isfinite(s.high)) {
            throw ConfigError(s.name + ": bounds must be finite numbers");
        }
        if (s.low > s.high) {
            throw ConfigError(s.name + ": low " + format_double(s.low) + " > high " +
                              format_double(s.high));
        }
        if (s.type == ParamType::kInt && (!is_integral(s.low) || !is_integral(s.high))) {
            throw ConfigError(s.name + ": integer parameter needs integer bounds");
        }
        if (s.log_scale && s.low <= 0) {
            throw ConfigError(s.name + ": log scale needs low > 0");
        }
        if (const std::string problem = rounding_problem(s); !problem.empty()) {
            throw ConfigError(s.name + ": " + problem);
        }
        const std::string problem = value_problem(s, s.default_value);
        if (!problem.empty()) throw ConfigError("default of " + problem);
    }
}

ParameterSpace ParameterSpace::load(const std::string& file) {
    return parse_space(load_yaml_file(file), file);
}

ParameterSpace ParameterSpace::parse(const std::string& yaml_text,
                                     const std::string& source_name) {
    return parse_space(load_yaml_string(yaml_text, source_name), source_name);
}

const ParameterSpec* ParameterSpace::find(const std::string& name) const {
    for (const auto& s : specs_) {
        if (s.name == name) return &s;
    }
    return nullptr;
}

ParameterSet ParameterSpace::defaults() const {
    ParameterSet set;
    for (const auto& s : specs_) set.set(s.name, s.default_value);
    return set;
}

ParameterSet ParameterSpace::complete(const ParameterSet& partial) const {
    ParameterSet full = defaults();
    for (const auto& [name, value] : partial) {
        const ParameterSpec* spec = find(name);
        if (spec == nullptr) throw ConfigError(name + ": unknown parameter of space '" + name_ + "'");
        const std::string problem = value_problem(*spec, value);
        if (!problem.empty()) throw ConfigError(problem);
        full.set(name, value);
    }
    return full;
}

std::string ParameterSpace::check(const ParameterSet& set) const {
    for (const auto& [name, value] : set) {
        const ParameterSpec* spec = find(name);
        if (spec == nullptr) return name + ": unknown parameter of space '" + name_ + "'";
        const std::string problem = value_problem(*spec, value);
        if (!problem.empty()) return problem;
    }
    for (const auto& s : specs_) {
        if (!set.has(s.name)) return s.name + ": missing";
    }
    return "";
}

ParameterSet ParameterSpace::round(const ParameterSet& set) const {
    ParameterSet out;
    for (const auto& [name, value] : set) {
        const ParameterSpec* spec = find(name);
        const bool is_int = spec != nullptr && spec->type == ParamType::kInt;
        out.set(name, is_int ? std::round(value) : std::stod(format_fixed(value, spec ? spec->decimals : 2)));
    }
    return out;
}

std::string ParameterSpace::canonical_key(const ParameterSet& set) const {
    std::string key;
    for (const auto& [name, value] : set) {  // std::map: sorted by name
        const ParameterSpec* spec = find(name);
        const bool is_int = spec != nullptr && spec->type == ParamType::kInt;
        if (!key.empty()) key += ';';
        key += name + "=" + format_fixed(value, is_int ? 0 : (spec ? spec->decimals : 2));
    }
    return key;
}

std::string ParameterSpace::hash() const {
    std::string text = name_;
    for (const auto& s : specs_) {
        text += "|" + s.name + ":" + type_name(s.type) + ":" + format_double(s.low) + ":" +
                format_double(s.high) + ":" + format_double(s.default_value) +
                (s.log_scale ? ":log" : "") + (s.decimals != 2 ? ":d" + std::to_string(s.decimals) : "");
    }
    std::uint64_t h = 1469598103934665603ULL;
    for (unsigned char c : text) {
        h ^= c;
        h *= 1099511628211ULL;
    }
    char buf[17];
    std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(h));
    return buf;
}

}  // namespace maptune::params
