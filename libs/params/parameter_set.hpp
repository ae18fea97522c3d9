#pragma once
// A parameter set: named numeric values, ordered by name. A plain value type used by the
// optimizer, the store and the wire; typed views (e.g. MatcherParams) convert from it.

#include <map>
#include <optional>
#include <string>

namespace maptune::params {

class ParameterSet {
public:
    ParameterSet() = default;
    ParameterSet(std::initializer_list<std::pair<const std::string, double>> values)
        : values_(values) {}

    void set(const std::string& name, double value) { values_[name] = value; }
    bool has(const std::string& name) const { return values_.count(name) != 0; }
    // Throws std::out_of_range naming the parameter when absent.
    double get(const std::string& name) const;
    std::optional<double> find(const std::string& name) const;
    std::size_t size() const { return values_.size(); }
    bool empty() const { return values_.empty(); }
    const std::map<std::string, double>& values() const { return values_; }

    auto begin() const { return values_.begin(); }
    auto end() const { return values_.end(); }
    bool operator==(const ParameterSet& other) const { return values_ == other.values_; }
    bool operator!=(const ParameterSet& other) const { return !(*this == other); }

private:
    std::map<std::string, double> values_;
};

class ParameterSpace;

// Reads a flat YAML mapping "name: value" (nested mappings join with dots), or a ROS 2
// parameter file ("node: ros__parameters: ..."), checked against `space` (unknown names,
// bounds, integer values); missing parameters take their defaults. Throws ConfigError.
ParameterSet load_parameter_set(const std::string& file, const ParameterSpace& space);
ParameterSet parse_parameter_set(const std::string& yaml_text, const std::string& source_name,
                                 const ParameterSpace& space);

}  // namespace maptune::params
