#include <gtest/gtest.h>

#include <filesystem>

#include "params/parameter_set.hpp"
#include "params/parameter_space.hpp"
#include "params/yaml_util.hpp"

namespace maptune::params {
namespace {

const std::string kConfigs = std::string(MAPTUNE_SOURCE_DIR) + "/configs";

ParameterSpace lru() { return ParameterSpace::load(kConfigs + "/spaces/lru_matcher.yaml"); }

// Expects parse to throw ConfigError whose message contains every fragment.
void expect_space_error(const std::string& yaml, std::initializer_list<const char*> fragments) {
    try {
        ParameterSpace::parse(yaml, "space.yaml");
        FAIL() << "no error for:\n" << yaml;
    } catch (const ConfigError& e) {
        for (const char* f : fragments) {
            EXPECT_NE(std::string(e.what()).find(f), std::string::npos)
                << "message '" << e.what() << "' lacks '" << f << "'";
        }
    }
}

TEST(ParameterSpace, LoadsTheLruMatcherSpaceOfSpecTable51) {
    const ParameterSpace space = lru();
    EXPECT_EQ(space.name(), "lru_matcher");
    ASSERT_EQ(space.size(), 9u);
    const std::vector<std::string> order{"r_N", "v_K", "t_K", "r_D", "n_C",
                                         "t_C", "r_LRF", "v_TF", "n_TF"};
    for (std::size_t i = 0; i < order.size(); ++i) EXPECT_EQ(space.specs()[i].name, order[i]);
    const ParameterSpec* n_tf = space.find("n_TF");
    ASSERT_NE(n_tf, nullptr);
    EXPECT_EQ(n_tf->type, ParamType::kInt);
    EXPECT_EQ(n_tf->low, 3);
    EXPECT_EQ(n_tf->high, 300);
    EXPECT_EQ(n_tf->default_value, 8);
    const ParameterSpec* r_n = space.find("r_N");
    EXPECT_EQ(r_n->unit, "m");
    EXPECT_DOUBLE_EQ(r_n->low, 0.1);
    EXPECT_DOUBLE_EQ(r_n->high, 2.0);
    EXPECT_EQ(space.find("nope"), nullptr);
}

TEST(ParameterSpace, EveryThesisParameterSetLoadsWithinBounds) {
    const ParameterSpace space = lru();
    int loaded = 0;
    for (const auto& entry : std::filesystem::directory_iterator(kConfigs + "/params")) {
        const ParameterSet set = load_parameter_set(entry.path().string(), space);
        EXPECT_EQ(space.check(set), "") << entry.path();
        ++loaded;
    }
    EXPECT_EQ(loaded, 6);
    const ParameterSet ssgt = load_parameter_set(kConfigs + "/params/x_9D_ssgt1.yaml", space);
    EXPECT_DOUBLE_EQ(ssgt.get("r_D"), 2.0);
    EXPECT_DOUBLE_EQ(ssgt.get("n_TF"), 63);
    const ParameterSet base = load_parameter_set(kConfigs + "/params/x_baseline.yaml", space);
    EXPECT_EQ(base, space.defaults());
}

TEST(ParameterSpace, ErrorsNameFileLineKeyAndExpectation) {
    expect_space_error("name: s\nparameters:\n  a: {type: float, low: 1, high: 0, default: 0.5}\n",
                       {"space.yaml:3", "parameters.a", "low 1.0 > high 0.0"});
    expect_space_error("name: s\nparameters:\n  a: {type: float, low: 0, high: 1, default: 2}\n",
                       {"space.yaml:3", "parameters.a.default", "outside [0.0, 1.0]"});
    expect_space_error("name: s\nparameters:\n  a: {type: float, low: .nan, high: 1, default: 0}\n",
                       {"parameters.a.low", "finite"});
    expect_space_error("name: s\nparameters:\n  a: {type: double, low: 0, high: 1, default: 0}\n",
                       {"parameters.a.type", "expected 'float' or 'int'", "double"});
    expect_space_error("name: s\nparameters:\n  a: {type: int, low: 0.5, high: 3, default: 1}\n",
                       {"parameters.a.low", "integer"});
    expect_space_error("name: s\nparameters:\n  a: {type: float, low: x, high: 1, default: 0}\n",
                       {"parameters.a.low", "expected a number, got 'x'"});
    expect_space_error(
        "name: s\nparameters:\n  a: {type: float, low: 0, high: 1, default: 0, colour: red}\n",
        {"parameters.a.colour", "unknown key"});
    expect_space_error("name: s\nparameters:\n  a: {type: float, low: 0, high: 1}\n",
                       {"parameters.a", "missing key 'default'"});
    expect_space_error(
        "name: s\nparameters:\n  a: {type: float, low: 0, high: 1, default: 0}\n"
        "  a: {type: float, low: 0, high: 2, default: 0}\n",
        {"space.yaml:4", "parameters.a", "duplicate key"});
    expect_space_error("name: s\nparameters: [1, 2\n", {"space.yaml", "invalid YAML"});
    expect_space_error("name: s\nbogus: 1\nparameters: {}\n", {"bogus", "unknown key"});
    expect_space_error(
        "name: s\nparameters:\n  a: {type: float, low: 0, high: 1, default: 0.5, log_scale: true}\n",
        {"parameters.a.log_scale", "low > 0"});
    expect_space_error("name: s\nparameters:\n  {x: 1}: {type: float, low: 0, high: 1, default: 0}\n",
                       {"space.yaml:3", "expected a plain name as key"});
    // Bounds whose rounded keys would overflow (1e299 once keyed as -92233720368547758.08).
    expect_space_error("name: s\nparameters:\n  a: {type: float, low: -1e300, high: 1e300, default: 0}\n",
                       {"space.yaml:3", "parameters.a", "too large to round to 2 decimals"});
    expect_space_error("name: s\nparameters:\n  a: {type: int, low: 0, high: 1e19, default: 0}\n",
                       {"parameters.a", "too large to round to 0 decimals"});
}

TEST(ParameterSpace, MissingFileIsAClearError) {
    try {
        ParameterSpace::load("/nonexistent/space.yaml");
        FAIL();
    } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("/nonexistent/space.yaml: cannot open"),
                  std::string::npos);
    }
}

TEST(ParameterSet, BadValuesInAParameterFileAreNamed) {
    const ParameterSpace space = lru();
    auto expect_error = [&](const std::string& yaml, const std::string& fragment) {
        try {
            parse_parameter_set(yaml, "set.yaml", space);
            FAIL() << yaml;
        } catch (const ConfigError& e) {
            EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
        }
    };
    expect_error("r_N: 0.2\nfoo: 1\n", "set.yaml:2: foo: unknown parameter");
    expect_error("r_N: 5.0\n", "r_N: 5.0 is outside [0.1, 2.0]");
    expect_error("n_C: 2.5\n", "n_C: expected an integer");
    expect_error("r_N: .nan\n", "r_N: expected a finite number");
    expect_error("r_N: abc\n", "expected a number, got 'abc'");
    // Issue 14: a mapping as key ended every command with std::terminate.
    expect_error("r_N: 0.2\n{a: 1}: 2\n", "set.yaml:2: <root>: expected a plain name as key");
    expect_error("{a: 1}: {ros__parameters: {r_N: 0.2}}\n", "expected a plain name as key");
    expect_error("r_N: 0.2\n[1, 2]: 3\n", "expected a plain name as key");
}

TEST(ParameterSet, MissingParametersTakeDefaultsAndRos2FilesLoad) {
    const ParameterSpace space = lru();
    const ParameterSet partial = parse_parameter_set("t_K: 0.95\nr_D: 0.34\n", "p.yaml", space);
    EXPECT_EQ(partial.size(), 9u);
    EXPECT_DOUBLE_EQ(partial.get("t_K"), 0.95);
    EXPECT_DOUBLE_EQ(partial.get("r_N"), 0.2);
    const ParameterSet ros = parse_parameter_set(
        "matcher:\n  ros__parameters:\n    t_K: 0.5\n    n_TF: 20\n", "ros.yaml", space);
    EXPECT_DOUBLE_EQ(ros.get("t_K"), 0.5);
    EXPECT_DOUBLE_EQ(ros.get("n_TF"), 20);
}

TEST(ParameterSpace, RoundingAndCanonicalKey) {
    const ParameterSpace space = lru();
    ParameterSet set = space.defaults();
    set.set("r_N", 0.23456);
    set.set("t_C", 0.005);  // exactly halfway in decimal, not in binary: must be stable
    set.set("n_TF", 7.6);
    const ParameterSet rounded = space.round(set);
    EXPECT_DOUBLE_EQ(rounded.get("r_N"), 0.23);
    EXPECT_DOUBLE_EQ(rounded.get("n_TF"), 8);
    EXPECT_EQ(space.canonical_key(set),
              "n_C=3;n_TF=8;r_D=0.20;r_LRF=0.20;r_N=0.23;t_C=0.01;t_K=1.00;v_K=0.10;v_TF=0.50");
    // Values that round to the same key are the same request.
    ParameterSet near = set;
    near.set("r_N", 0.2349);
    EXPECT_EQ(space.canonical_key(near), space.canonical_key(set));
    near.set("r_N", 0.2351);
    EXPECT_NE(space.canonical_key(near), space.canonical_key(set));
    // The key of a rounded set is the key of the set.
    EXPECT_EQ(space.canonical_key(rounded), space.canonical_key(set));
}

TEST(ParameterSpace, KeyIsStableAcrossProcessesAndPlatforms) {
    // Golden values: any change in formatting or hashing breaks every stored database.
    const ParameterSpace space = lru();
    EXPECT_EQ(space.canonical_key(space.defaults()),
              "n_C=3;n_TF=8;r_D=0.20;r_LRF=0.20;r_N=0.20;t_C=0.50;t_K=1.00;v_K=0.10;v_TF=0.50");
    EXPECT_EQ(space.hash(), space.hash());
    EXPECT_EQ(space.hash().size(), 16u);
    EXPECT_EQ(lru().hash(), space.hash());
    const ParameterSpace other("lru_matcher", {{"r_N", ParamType::kFloat, 0.1, 2.5, 0.2}});
    EXPECT_NE(other.hash(), space.hash());
}

TEST(FormatFixed, RoundsHalfAwayFromZeroWithoutLocale) {
    EXPECT_EQ(format_fixed(0.125, 2), "0.13");
    EXPECT_EQ(format_fixed(-0.125, 2), "-0.13");
    EXPECT_EQ(format_fixed(-0.001, 2), "0.00");
    EXPECT_EQ(format_fixed(2, 2), "2.00");
    EXPECT_EQ(format_fixed(299.5, 0), "300");
    EXPECT_EQ(format_fixed(1.05, 1), "1.1");
}

TEST(FormatDouble, AlwaysHasADecimalPointAndRoundTrips) {
    EXPECT_EQ(format_double(2), "2.0");
    EXPECT_EQ(format_double(0.5), "0.5");
    EXPECT_EQ(format_double(1e-5), "1.0e-05");
    EXPECT_EQ(format_double(-3), "-3.0");
    EXPECT_EQ(format_double(0.1 + 0.2), "0.30000000000000004");
    for (double v : {0.1, 1.0 / 3.0, 123456.789, 1e300, -2.5e-300}) {
        EXPECT_EQ(std::stod(format_double(v)), v);
    }
}

}  // namespace
}  // namespace maptune::params
