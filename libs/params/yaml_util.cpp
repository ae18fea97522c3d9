#include "params/yaml_util.hpp"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace maptune::params {

YamlPath YamlPath::child(const std::string& key) const {
    return {file, path.empty() ? key : path + "." + key};
}

YamlPath YamlPath::index(std::size_t i) const {
    return {file, path + "[" + std::to_string(i) + "]"};
}

std::string YamlPath::where(const YAML::Node& node) const {
    std::ostringstream msg;
    msg << file;
    if (node.IsDefined() && node.Mark().line >= 0) msg << ":" << node.Mark().line + 1;
    msg << ": " << (path.empty() ? "<root>" : path);
    return msg.str();
}

void YamlPath::fail(const YAML::Node& node, const std::string& what) const {
    throw ConfigError(where(node) + ": " + what);
}

std::string read_text_file(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw ConfigError(file + ": cannot open file");
    std::stringstream text;
    text << in.rdbuf();
    if (in.bad()) throw ConfigError(file + ": read error");
    return text.str();
}

YAML::Node load_yaml_file(const std::string& file) {
    return load_yaml_string(read_text_file(file), file);
}

YAML::Node load_yaml_string(const std::string& text, const std::string& source_name) {
    try {
        return YAML::Load(text);
    } catch (const YAML::Exception& e) {
        throw ConfigError(source_name + ":" + std::to_string(e.mark.line + 1) +
                          ": invalid YAML: " + e.msg);
    }
}

void require_map(const YAML::Node& node, const YamlPath& where) {
    if (!node.IsMap()) where.fail(node, "expected a mapping");
}

void check_unique_keys(const YAML::Node& map, const YamlPath& where) {
    require_map(map, where);
    std::set<std::string> seen;
    for (const auto& kv : map) {
        // A mapping or list as key ({a: 1}: 2) is valid YAML but never a name here.
        if (!kv.first.IsScalar()) where.fail(kv.first, "expected a plain name as key, not a mapping or list");
        const auto key = kv.first.as<std::string>();
        if (!seen.insert(key).second) where.child(key).fail(kv.first, "duplicate key");
    }
}

void check_keys(const YAML::Node& map, const YamlPath& where,
                std::initializer_list<const char*> allowed) {
    check_unique_keys(map, where);
    for (const auto& kv : map) {
        const auto key = kv.first.as<std::string>();
        bool known = false;
        std::string expected;
        for (const char* a : allowed) {
            known = known || key == a;
            expected += expected.empty() ? a : std::string(", ") + a;
        }
        if (!known) where.child(key).fail(kv.first, "unknown key (expected one of: " + expected + ")");
    }
}

double read_finite_double(const YAML::Node& node, const YamlPath& where) {
    if (!node.IsDefined() || node.IsNull()) where.fail(node, "missing value (expected a number)");
    if (!node.IsScalar()) where.fail(node, "expected a number");
    const std::string text = node.Scalar();
    // YAML spells non-finite floats .nan / .inf; they are never valid here.
    for (const char* special : {".nan", ".NaN", ".NAN", ".inf", ".Inf", ".INF", "+.inf", "-.inf",
                                "-.Inf", "-.INF", "nan", "inf", "-inf"}) {
        if (text == special) where.fail(node, "expected a finite number, got '" + text + "'");
    }
    double value = 0;
    try {
        std::size_t used = 0;
        value = std::stod(text, &used);
        if (used != text.size()) throw std::invalid_argument(text);
    } catch (const std::exception&) {
        where.fail(node, "expected a number, got '" + text + "'");
    }
    if (!std::isfinite(value)) where.fail(node, "expected a finite number, got '" + text + "'");
    return value;
}

std::string read_string(const YAML::Node& node, const YamlPath& where) {
    if (!node.IsDefined() || !node.IsScalar()) where.fail(node, "expected a string");
    return node.Scalar();
}

bool read_bool(const YAML::Node& node, const YamlPath& where) {
    if (!node.IsDefined() || !node.IsScalar()) where.fail(node, "expected true or false");
    const std::string& s = node.Scalar();
    if (s == "true" || s == "True" || s == "yes") return true;
    if (s == "false" || s == "False" || s == "no") return false;
    where.fail(node, "expected true or false, got '" + s + "'");
}

}  // namespace maptune::params
