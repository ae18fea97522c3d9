#include <gtest/gtest.h>

#include "matcher/feature_cache.hpp"
#include "matcher/matcher_params.hpp"

namespace maptune::matcher {
namespace {

TEST(MatcherParams, DefaultsAreBaseline) {
    const auto m = to_named_values(MatcherParams{});
    const std::map<std::string, double> baseline{{"r_N", 0.2},   {"v_K", 0.1},  {"t_K", 1.0},
                                                 {"r_D", 0.2},   {"n_C", 3},    {"t_C", 0.5},
                                                 {"r_LRF", 0.2}, {"v_TF", 0.5}, {"n_TF", 8}};
    EXPECT_EQ(m, baseline);
    EXPECT_EQ(parameter_names().size(), 9u);
    for (const auto& name : parameter_names()) EXPECT_TRUE(m.count(name)) << name;
}

TEST(MatcherParams, RoundTripAndIntegerRounding) {
    const std::map<std::string, double> x9d{{"r_N", 0.1},   {"v_K", 0.05}, {"t_K", 1.0},
                                            {"r_D", 2.0},   {"n_C", 9.6},  {"t_C", 1.0},
                                            {"r_LRF", 0.1}, {"v_TF", 0.1}, {"n_TF", 63.2}};
    const auto p = from_named_values(x9d);
    EXPECT_EQ(p.n_C, 10);
    EXPECT_EQ(p.n_TF, 63);
    EXPECT_DOUBLE_EQ(p.r_D, 2.0);
    const auto back = from_named_values(to_named_values(p));
    EXPECT_EQ(to_named_values(back), to_named_values(p));
    EXPECT_EQ(from_named_values({}).n_TF, 8);  // missing keys keep the baseline
}

TEST(MatcherParams, ClampToBounds) {
    MatcherParams p;
    p.r_N = 5.0;
    p.n_C = 0;
    p.t_C = -1;
    EXPECT_EQ(clamp_to_bounds(p), 3);
    EXPECT_DOUBLE_EQ(p.r_N, 2.0);
    EXPECT_EQ(p.n_C, 1);
    EXPECT_DOUBLE_EQ(p.t_C, 0.0);
}

TEST(FeatureKey, PairStageParametersDoNotChangeTheKey) {
    dataset::Submap s;
    s.id = "run00/submap000";
    MatcherParams p, q;
    q.n_C = 7, q.t_C = 0.9, q.v_TF = 0.2, q.n_TF = 100;
    EXPECT_EQ(feature_key(s, p, {}, 0.01), feature_key(s, q, {}, 0.01));
    q.r_D = 0.204;  // rounds to the same 2 decimals
    EXPECT_EQ(feature_key(s, p, {}, 0.01), feature_key(s, q, {}, 0.01));
    q.r_D = 0.21;
    EXPECT_NE(feature_key(s, p, {}, 0.01), feature_key(s, q, {}, 0.01));
    EXPECT_DOUBLE_EQ(quantize_feature_params(q, 0.01).r_D, 0.21);
}

// Issue 12: the cache keyed on submap id and point counts, so a submap whose files changed
// under the same id (same sizes) got the old submap's features.
TEST(FeatureKey, ContentChangedUnderTheSameIdIsAnotherKey) {
    dataset::Submap s;
    s.id = "run00/submap000";
    s.cloud.resize(3);
    s.obstacles.resize(2, Eigen::Vector3f::Zero());
    const MatcherParams p;
    const std::string before = feature_key(s, p, {}, 0.01);
    EXPECT_EQ(before, feature_key(s, p, {}, 0.01));
    s.cloud[1].x = 0.5f;  // same id, same sizes, other content
    EXPECT_NE(before, feature_key(s, p, {}, 0.01));
    s.cloud[1].x = 0.f;
    s.obstacles[0].z() = 0.1f;
    EXPECT_NE(before, feature_key(s, p, {}, 0.01));
    // Loaded submaps carry the hash of their files, which decides alone.
    dataset::Submap a = s, b = s;
    a.content_hash = 1;
    b.content_hash = 2;
    EXPECT_NE(feature_key(a, p, {}, 0.01), feature_key(b, p, {}, 0.01));
}

}  // namespace
}  // namespace maptune::matcher
