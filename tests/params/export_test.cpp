#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "params/export.hpp"
#include "params/parameter_set.hpp"
#include "params/parameter_space.hpp"

namespace maptune::params {
namespace {

ParameterSpace lru() {
    return ParameterSpace::load(std::string(MAPTUNE_SOURCE_DIR) + "/configs/spaces/lru_matcher.yaml");
}

TEST(Ros2Export, DoublesHaveADecimalPointIntegersDoNot) {
    const ParameterSpace space = lru();
    const std::string text = to_ros2_yaml(space.defaults(), space, "map_matcher");
    EXPECT_NE(text.find("map_matcher:\n  ros__parameters:\n"), std::string::npos);
    EXPECT_NE(text.find("    t_K: 1.0\n"), std::string::npos) << text;
    EXPECT_NE(text.find("    r_N: 0.2\n"), std::string::npos);
    EXPECT_NE(text.find("    n_TF: 8\n"), std::string::npos);
    EXPECT_NE(text.find("    n_C: 3\n"), std::string::npos);
}

TEST(Ros2Export, RoundTripsThroughAYamlParser) {
    const ParameterSpace space = lru();
    ParameterSet set = space.defaults();
    set.set("r_D", 2.0);
    set.set("t_C", 0.73);
    set.set("n_TF", 123);
    const std::string text = to_ros2_yaml(set, space, "matcher");
    const YAML::Node root = YAML::Load(text);
    const YAML::Node p = root["matcher"]["ros__parameters"];
    ASSERT_TRUE(p.IsMap());
    EXPECT_EQ(p.size(), 9u);
    EXPECT_EQ(p["r_D"].Scalar(), "2.0");
    EXPECT_EQ(p["n_TF"].Scalar(), "123");
    EXPECT_DOUBLE_EQ(p["t_C"].as<double>(), 0.73);
    // And through our own loader.
    EXPECT_EQ(parse_parameter_set(text, "ros.yaml", space), set);
}

TEST(Ros2Export, DottedNamesNest) {
    const ParameterSpace space("s", {{"icp.max_iter", ParamType::kInt, 1, 100, 30},
                                     {"icp.tolerance", ParamType::kFloat, 0, 1, 0.01},
                                     {"keypoints.leaf", ParamType::kFloat, 0.01, 1, 0.1},
                                     {"top", ParamType::kFloat, 0, 10, 3}});
    const std::string text = to_ros2_yaml(space.defaults(), space, "node");
    EXPECT_EQ(text,
              "node:\n  ros__parameters:\n"
              "    icp:\n      max_iter: 30\n      tolerance: 0.01\n"
              "    keypoints:\n      leaf: 0.1\n"
              "    top: 3.0\n");
    EXPECT_EQ(parse_parameter_set(text, "n.yaml", space), space.defaults());
}

TEST(PlainExport, RoundTripsWithHeaderComments) {
    const ParameterSpace space = lru();
    ParameterSet set = space.defaults();
    set.set("v_TF", 0.63);
    const std::string text = to_plain_yaml(set, space, "best of run 3\np = 0.71");
    EXPECT_EQ(text.rfind("# best of run 3\n# p = 0.71\n", 0), 0u);
    EXPECT_NE(text.find("v_TF: 0.63\n"), std::string::npos);
    EXPECT_EQ(parse_parameter_set(text, "plain.yaml", space), set);
}

}  // namespace
}  // namespace maptune::params
