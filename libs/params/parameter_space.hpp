#pragma once
// The design space of a matcher: named parameters with type, bounds and default.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace maptune::params {

enum class ParamType { kFloat, kInt };

struct ParameterSpec {
    std::string name;         // unique; dots nest in the ROS 2 export ("icp.max_iter")
    ParamType type = ParamType::kFloat;
    double low = 0;           // inclusive bound
    double high = 0;          // inclusive bound
    double default_value = 0; // used for parameters that an experiment does not optimize
    std::string unit;         // e.g. "m", "" for dimensionless
    std::string description;
    bool log_scale = false;   // optimizer searches log(value); requires low > 0
    // Floats are rounded to this many decimals before evaluation and in store keys (the
    // thesis's matcher resolution is 0.01; a black-box space may need more, `decimals: 6`).
    int decimals = 2;
};

class ParameterSet;

class ParameterSpace {
public:
    ParameterSpace() = default;
    // Validates (names unique and non-empty, low <= high, default within bounds, integer
    // bounds/defaults integral, log scale only for low > 0); throws ConfigError.
    ParameterSpace(std::string name, std::vector<ParameterSpec> specs);

    // Loads the YAML schema documented in docs/configuration.md; throws ConfigError naming
    // the file, line and key path.
    static ParameterSpace load(const std::string& file);
    static ParameterSpace parse(const std::string& yaml_text, const std::string& source_name);

    const std::string& name() const { return name_; }
    const std::vector<ParameterSpec>& specs() const { return specs_; }
    std::size_t size() const { return specs_.size(); }
    const ParameterSpec* find(const std::string& name) const;

    // The defaults of every parameter.
    ParameterSet defaults() const;
    // `partial` with every missing parameter set to its default. Throws ConfigError for
    // unknown names, values outside the bounds, non-integral integers or NaN.
    ParameterSet complete(const ParameterSet& partial) const;
    // Empty string when `set` holds exactly this space's parameters, each valid; otherwise
    // what is wrong (the first problem found).
    std::string check(const ParameterSet& set) const;
    // Floats rounded to their `decimals` (default 2), integers to integers: the form stored
    // and compared.
    ParameterSet round(const ParameterSet& set) const;
    // Canonical text of the rounded full set, e.g. "n_C=3;r_N=0.20;..." (sorted by name).
    // Identical on every platform for the same values: used as the observation key.
    std::string canonical_key(const ParameterSet& set) const;
    // 64-bit FNV-1a of the canonical description of the space (names, types, bounds,
    // defaults) as 16 hex digits: workers and optimizer compare it to agree on the space.
    std::string hash() const;

private:
    std::string name_;
    std::vector<ParameterSpec> specs_;
};

// Rounds to `decimals` decimals and formats with exactly that many, independent of locale.
std::string format_fixed(double value, int decimals);
// Shortest text that parses back to `value`, always with a decimal point ("2.0", "1.0e-05").
std::string format_double(double value);

}  // namespace maptune::params
