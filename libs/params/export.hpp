#pragma once
// Writing parameter sets for robots: a ROS 2 parameter file and plain YAML.

#include <string>

#include "params/parameter_set.hpp"
#include "params/parameter_space.hpp"

namespace maptune::params {

// "node:\n  ros__parameters:\n    name: value" with dotted names nested. Doubles always carry
// a decimal point (an integer literal for a double parameter makes rclcpp's
// declare_parameter throw); integer parameters are written as integers.
std::string to_ros2_yaml(const ParameterSet& set, const ParameterSpace& space,
                         const std::string& node_name);
// Flat "name: value" lines, same number formatting; `header` lines become comments.
std::string to_plain_yaml(const ParameterSet& set, const ParameterSpace& space,
                          const std::string& header = "");

}  // namespace maptune::params
