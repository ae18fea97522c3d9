#pragma once
// Checked reading of YAML configuration: every error names the file, the line and the full
// key path of the offending node, and says what was expected.

#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <stdexcept>
#include <string>

namespace maptune::params {

// Thrown at start-up when a configuration file is missing, malformed or breaks its schema.
class ConfigError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Where a node sits, for error messages: "file:line: key.path".
struct YamlPath {
    std::string file;  // file name or "<string>"
    std::string path;  // dotted key path, "" for the document root

    YamlPath child(const std::string& key) const;
    YamlPath index(std::size_t i) const;
    // "file:line: path" of `node` (no line when the node has none): what errors name.
    std::string where(const YAML::Node& node) const;
    [[noreturn]] void fail(const YAML::Node& node, const std::string& what) const;
};

// The whole file as text; throws ConfigError naming the file when it cannot be read.
std::string read_text_file(const std::string& file);
// Parses a whole file; throws ConfigError naming the file on I/O or syntax errors.
YAML::Node load_yaml_file(const std::string& file);
YAML::Node load_yaml_string(const std::string& text, const std::string& source_name);

// Rejects keys of `map` that are not in `allowed` and duplicate keys.
void check_keys(const YAML::Node& map, const YamlPath& where,
                std::initializer_list<const char*> allowed);
// Requires a mapping without duplicate keys.
void check_unique_keys(const YAML::Node& map, const YamlPath& where);
void require_map(const YAML::Node& node, const YamlPath& where);

double read_finite_double(const YAML::Node& node, const YamlPath& where);
std::string read_string(const YAML::Node& node, const YamlPath& where);
bool read_bool(const YAML::Node& node, const YamlPath& where);

}  // namespace maptune::params
