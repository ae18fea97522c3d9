#include "params/export.hpp"

#include <cmath>
#include <sstream>
#include <vector>

namespace maptune::params {
namespace {

std::string format_value(const ParameterSpace& space, const std::string& name, double value) {
    const ParameterSpec* spec = space.find(name);
    if (spec != nullptr && spec->type == ParamType::kInt) return format_fixed(value, 0);
    return format_double(value);
}

std::vector<std::string> split_dots(const std::string& name) {
    std::vector<std::string> parts;
    std::string part;
    std::istringstream in(name);
    while (std::getline(in, part, '.')) parts.push_back(part);
    return parts;
}

}  // namespace

std::string to_ros2_yaml(const ParameterSet& set, const ParameterSpace& space,
                         const std::string& node_name) {
    std::ostringstream out;
    out << node_name << ":\n  ros__parameters:\n";
    // The set is sorted by name, so names sharing a dotted prefix are adjacent: open only the
    // levels that differ from the previous name.
    std::vector<std::string> open;
    for (const auto& [name, value] : set) {
        const auto parts = split_dots(name);
        std::size_t common = 0;
        while (common < open.size() && common + 1 < parts.size() && open[common] == parts[common]) {
            ++common;
        }
        open.resize(common);
        for (std::size_t i = common; i + 1 < parts.size(); ++i) {
            out << std::string(4 + 2 * i, ' ') << parts[i] << ":\n";
            open.push_back(parts[i]);
        }
        out << std::string(4 + 2 * (parts.size() - 1), ' ') << parts.back() << ": "
            << format_value(space, name, value) << "\n";
    }
    return out.str();
}

std::string to_plain_yaml(const ParameterSet& set, const ParameterSpace& space,
                          const std::string& header) {
    std::ostringstream out;
    std::istringstream lines(header);
    for (std::string line; std::getline(lines, line);) out << "# " << line << "\n";
    for (const auto& [name, value] : set) {
        out << name << ": " << format_value(space, name, value) << "\n";
    }
    return out.str();
}

}  // namespace maptune::params
