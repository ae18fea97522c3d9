#include "params/parameter_set.hpp"

#include <stdexcept>

#include "params/parameter_space.hpp"
#include "params/yaml_util.hpp"

namespace maptune::params {

double ParameterSet::get(const std::string& name) const {
    const auto it = values_.find(name);
    if (it == values_.end()) throw std::out_of_range("parameter '" + name + "' is not set");
    return it->second;
}

std::optional<double> ParameterSet::find(const std::string& name) const {
    const auto it = values_.find(name);
    if (it == values_.end()) return std::nullopt;
    return it->second;
}

namespace {

// Flattens nested mappings into dotted names, checking each value against the space.
void collect(const YAML::Node& node, const YamlPath& where, const std::string& prefix,
             const ParameterSpace& space, ParameterSet& out) {
    check_unique_keys(node, where);
    for (const auto& kv : node) {
        const std::string key = kv.first.as<std::string>();
        const std::string name = prefix.empty() ? key : prefix + "." + key;
        const YamlPath p = where.child(key);
        if (kv.second.IsMap()) {
            collect(kv.second, p, name, space, out);
            continue;
        }
        const ParameterSpec* spec = space.find(name);
        if (spec == nullptr) {
            p.fail(kv.first, "unknown parameter (not in space '" + space.name() + "')");
        }
        const double value = read_finite_double(kv.second, p);
        ParameterSet one;
        one.set(name, value);
        try {
            space.complete(one);
        } catch (const ConfigError& e) {
            p.fail(kv.second, e.what());
        }
        out.set(name, value);
    }
}

}  // namespace

ParameterSet parse_parameter_set(const std::string& yaml_text, const std::string& source_name,
                                 const ParameterSpace& space) {
    const YAML::Node root = load_yaml_string(yaml_text, source_name);
    YamlPath where{source_name, ""};
    if (root.IsNull()) return space.defaults();
    require_map(root, where);
    YAML::Node values = root;
    // A ROS 2 parameter file: a single node whose mapping holds "ros__parameters".
    if (root.size() == 1) {
        const auto first = *root.begin();
        if (first.first.IsScalar() && first.second.IsMap() && first.second["ros__parameters"].IsDefined()) {
            where = where.child(first.first.as<std::string>()).child("ros__parameters");
            values = first.second["ros__parameters"];
        }
    }
    ParameterSet set;
    collect(values, where, "", space, set);
    return space.complete(set);
}

ParameterSet load_parameter_set(const std::string& file, const ParameterSpace& space) {
    return parse_parameter_set(read_text_file(file), file, space);
}

}  // namespace maptune::params
