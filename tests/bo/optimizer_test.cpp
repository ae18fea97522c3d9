#include "bo/optimizer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "bo/benchmark.hpp"
#include "bo/test_functions.hpp"

namespace maptune::bo {
namespace {

std::vector<Proposal> run(Optimizer& opt, const TestFunction& fn, int evaluations, int q) {
    std::vector<Proposal> all;
    while (static_cast<int>(all.size()) < evaluations) {
        for (const Proposal& p : opt.ask(q)) {
            EXPECT_TRUE(opt.tell(p.id, fn.f(p.values)));
            all.push_back(p);
        }
    }
    return all;
}

OptimizerOptions fast_options(std::uint64_t seed) {
    OptimizerOptions o;
    o.direction = Direction::minimize;
    o.seed = seed;
    o.candidates = 500;
    o.polish_starts = 3;
    return o;
}

TEST(OptimizerTest, DeterministicGivenSeed) {
    const TestFunction fn = branin();
    Optimizer a(fn.space, fast_options(5)), b(fn.space, fast_options(5)),
        c(fn.space, fast_options(6));
    const auto pa = run(a, fn, 20, 2);
    const auto pb = run(b, fn, 20, 2);
    const auto pc = run(c, fn, 20, 2);
    for (std::size_t i = 0; i < pa.size(); ++i) EXPECT_EQ(pa[i].values, pb[i].values) << i;
    EXPECT_NE(pa.back().values, pc.back().values);
}

TEST(OptimizerTest, ThreadCountDoesNotChangeProposals) {
    // Threads split the GP's prediction batches, the fit's starts and the acquisition polishes;
    // every result is merged in a fixed order, so the run must be identical.
    const TestFunction fn = hartmann6();
    OptimizerOptions one = fast_options(8), two = fast_options(8);
    one.gp.threads = 1;
    two.gp.threads = 2;
    Optimizer a(fn.space, one), b(fn.space, two);
    const auto pa = run(a, fn, 30, 2);
    const auto pb = run(b, fn, 30, 2);
    ASSERT_EQ(pa.size(), pb.size());
    for (std::size_t i = 0; i < pa.size(); ++i) EXPECT_EQ(pa[i].values, pb[i].values) << i;
    EXPECT_EQ(a.hyperparameters().to_log(), b.hyperparameters().to_log());
}

// Issue 15: the warping is chosen by marginal likelihood — the log for values over orders of
// magnitude — and the model's predictions map back to the objective's units.
TEST(OptimizerTest, AutomaticWarpingPicksTheLogForValuesOverOrdersOfMagnitude) {
    const TestFunction fn = ellipsoid(9);  // 0 .. 3e7
    Optimizer opt(fn.space, fast_options(3));
    run(opt, fn, 60, 1);
    EXPECT_EQ(opt.warping_in_use().rfind("log", 0), 0u) << opt.warping_in_use();
    const auto best = opt.best();
    ASSERT_TRUE(best);
    const auto post = opt.posterior({best->values});
    ASSERT_EQ(post.size(), 1u);
    // At an observation the posterior mean maps back to about the value (the log warping's
    // offset c = 0.1 range flattens differences far below c, hence the tolerance).
    double worst = best->value;
    for (const auto& o : opt.observations()) worst = std::max(worst, o.value);
    const double range = worst - best->value;
    EXPECT_NEAR(post[0].mean, best->value, 0.01 * range) << best->value << " range " << range;
    const auto pb = opt.predicted_best();
    ASSERT_TRUE(pb);
    EXPECT_GT(pb->mean, -0.01 * range);                  // not below the minimum (0) by much
    EXPECT_LT(pb->mean, best->value + 0.01 * range);     // and in the units of the values
    EXPECT_EQ(opt.warping_in_use() == "none", false);

    // A fixed warping is reported as such.
    OptimizerOptions none = fast_options(3);
    none.warping = OutputWarping::none;
    Optimizer plain(fn.space, none);
    run(plain, fn, 25, 1);
    EXPECT_EQ(plain.warping_in_use(), "none");
}

// While the automatic warping keeps choosing the identity, its runs are the fixed identity's
// ("none"): the same fits from the same starts, and EI's incumbent the best value under both.
// (The chosen identity's incumbent was once taken as 0 at every refit.)
TEST(OptimizerTest, AutomaticWarpingThatKeepsTheIdentityProposesAsNoWarping) {
    const TestFunction fn = hartmann6();
    OptimizerOptions automatic = fast_options(3), none = fast_options(3);
    none.warping = OutputWarping::none;
    Optimizer a(fn.space, automatic), b(fn.space, none);
    int compared = 0;
    for (int i = 0; i < 30; ++i) {
        const Proposal pa = a.ask(1).front();
        const Proposal pb = b.ask(1).front();
        if (i >= a.initial_points()) {
            if (a.warping_in_use() != "none") break;
            ASSERT_EQ(pa.values, pb.values) << i;
            ++compared;
        }
        ASSERT_TRUE(a.tell(pa.id, fn.f(pa.values)));
        ASSERT_TRUE(b.tell(pb.id, fn.f(pb.values)));
    }
    EXPECT_GE(compared, 10);
}

// A few huge values (the ellipsoid's far corners) set the range; with c = 0.1 × range every
// good value looked alike under the log. The likelihood picks a smaller offset here.
TEST(OptimizerTest, WarpingOffsetIsChosenBelowTheRangeWhenCornersDominateIt) {
    const TestFunction fn = ellipsoid(9);
    Optimizer opt(fn.space, fast_options(3));
    run(opt, fn, 60, 1);
    const std::string w = opt.warping_in_use();
    EXPECT_TRUE(w == "log(c = 0.01 range)" || w == "log(c = 0.001 range)") << w;
}

// The trust region halves after max(4, d) proposals without improvement and its proposals
// stay inside it (search: trust_region).
TEST(OptimizerTest, TrustRegionShrinksWithoutImprovementAndHoldsItsProposals) {
    const std::vector<ParameterSpec> specs = {{"x1", 0, 1}, {"x2", 0, 1}, {"x3", 0, 1}};
    OptimizerOptions o = fast_options(2);
    o.direction = Direction::maximize;
    o.search = SearchRegion::trust_region;
    o.initial_points = 6;
    Optimizer opt(specs, o);
    // A flat objective after the design: nothing ever improves.
    for (int i = 0; i < 6; ++i) {
        const auto p = opt.ask(1)[0];
        opt.tell(p.id, -static_cast<double>(i));  // the first design point stays the best
    }
    EXPECT_DOUBLE_EQ(opt.trust_region_side(), 0.8);
    const auto centre = opt.best()->values;
    for (int i = 0; i < 8; ++i) {
        const auto p = opt.ask(1)[0];
        for (std::size_t j = 0; j < 3; ++j) {
            // Length scales weight the sides (geometric mean = side), so allow the widest one.
            EXPECT_LE(std::fabs(p.values[j] - centre[j]), 0.5 + 1e-9) << i;
        }
        opt.tell(p.id, -10.0);
    }
    EXPECT_DOUBLE_EQ(opt.trust_region_side(), 0.2);  // 8 failures, tolerance 4: halved twice
}

// Issue 15: between refits new observations are appended to the cached factor (no
// refactorization), and a restored optimizer proposes what the original would have.
TEST(OptimizerTest, BuildsBetweenRefitsAppendToTheCachedFactor) {
    const TestFunction fn = hartmann6();
    OptimizerOptions o = fast_options(4);
    o.refit_growth = 0.25;  // refit when the data grew by a quarter
    Optimizer opt(fn.space, o);
    run(opt, fn, 60, 1);
    const auto& st = opt.model_stats();
    EXPECT_GT(st.appends, 20u);
    EXPECT_EQ(st.factorizations, st.refits);  // every other build appended
    // The same history replayed (as after a restart) gives the same next proposals.
    Optimizer again(fn.space, o);
    std::vector<std::string> origins;
    for (std::size_t i = 0; i < opt.observations().size(); ++i) {
        origins.push_back(i < static_cast<std::size_t>(opt.initial_points()) ? "initial" : "model");
    }
    again.replay(opt.observations(), origins);
    const auto a = opt.ask(1), b = again.ask(1);
    ASSERT_EQ(a.size(), 1u);
    ASSERT_EQ(b.size(), 1u);
    EXPECT_EQ(a[0].values, b[0].values);
}

// Issue 15: with a dead-region model (p = 0 is "no match at all") fewer proposals land in a
// dead half of the box whose edge is the best place of the live half.
TEST(OptimizerTest, DeadRegionModelKeepsProposalsOutOfDeadRegions) {
    const std::vector<ParameterSpec> specs = {{"x1", 0, 1}, {"x2", 0, 1}};
    auto f = [](const std::vector<double>& x) {
        return x[0] < 0.5 ? 0.0 : 1.5 - x[0] - (x[1] - 0.3) * (x[1] - 0.3);  // cliff at the best
    };
    auto dead_proposals = [&](bool model_dead, std::uint64_t seed) {
        OptimizerOptions o = fast_options(seed);
        o.direction = Direction::maximize;
        // The acquisition's weighting by P(live) alone: quadratic steps never step past the last
        // live point (QuadraticStepsStayInsideTheLiveData) and, with the incumbent at the cliff
        // sooner, change how often the region's other proposals straddle it.
        o.quadratic_steps = false;
        if (model_dead) o.dead_value = 0.0;
        Optimizer opt(specs, o);
        int dead = 0;
        for (int i = 0; i < 40; ++i) {
            const Proposal p = opt.ask(1)[0];
            if (p.origin == "model" && p.values[0] < 0.5) ++dead;
            opt.tell(p.id, f(p.values));
        }
        return dead;
    };
    int with = 0, without = 0;
    for (std::uint64_t seed : {1, 2, 3}) {
        with += dead_proposals(true, seed);
        without += dead_proposals(false, seed);
    }
    EXPECT_LT(with, without);
}

// A quadratic step fits the live values only and stays inside the box they span, so on a
// cliff whose best values lie at its edge it does not step over it.
TEST(OptimizerTest, QuadraticStepsStayInsideTheLiveData) {
    const std::vector<ParameterSpec> specs = {{"x1", 0, 1}, {"x2", 0, 1}};
    auto f = [](const std::vector<double>& x) {
        return x[0] < 0.5 ? 0.0 : 1.5 - x[0] - (x[1] - 0.3) * (x[1] - 0.3);
    };
    int quadratic_slots = 0, dead = 0;
    for (std::uint64_t seed : {1, 2, 3, 4}) {
        OptimizerOptions o = fast_options(seed);
        o.direction = Direction::maximize;
        o.dead_value = 0.0;
        Optimizer opt(specs, o);
        for (int i = 0; i < 40; ++i) {
            const Proposal p = opt.ask(1)[0];
            if (p.origin == "quadratic") {
                ++quadratic_slots;
                if (p.values[0] < 0.5) ++dead;
            }
            opt.tell(p.id, f(p.values));
        }
    }
    EXPECT_GT(quadratic_slots, 10);
    EXPECT_EQ(dead, 0);
}

// Issue 15: while every result is dead (the moon's baseline and whole design matched nothing)
// all values are the same to a model, which then sent its proposals to corners; the
// quasi-random design goes on until a live result exists, then the model takes over.
TEST(OptimizerTest, UntilALiveResultTheDesignGoesOn) {
    const std::vector<ParameterSpec> specs = {{"x1", 0, 1}, {"x2", 0, 1}};
    OptimizerOptions o = fast_options(3);
    o.direction = Direction::maximize;
    o.initial_points = 5;
    o.dead_value = 0.0;
    Optimizer opt(specs, o);
    for (int i = 0; i < 12; ++i) {
        const Proposal p = opt.ask(1)[0];
        EXPECT_EQ(p.origin, "initial") << "proposal " << i;
        opt.tell(p.id, i == 11 ? 0.5 : 0.0);
    }
    EXPECT_EQ(opt.ask(1)[0].origin, "model");
    // Without a dead value, equal values are a result like any other: the model proposes.
    o.dead_value.reset();
    Optimizer plain(specs, o);
    for (int i = 0; i < 5; ++i) plain.tell(plain.ask(1)[0].id, 0.0);
    EXPECT_EQ(plain.ask(1)[0].origin, "model");
}

// Issue 15: the labels below never vary along x3 where results are live (all at x3 = 0.2); a
// classifier that fitted x3 away as irrelevant rated (0.25, 0.25, 0.95) as surely live as the
// cluster itself. Far from its labels P(live) must fall towards the design's share of live
// results (none of six here).
TEST(OptimizerTest, DeadRegionClassifierDoesNotExtrapolateAlongUnseenDimensions) {
    const std::vector<ParameterSpec> specs = {{"x1", 0, 1}, {"x2", 0, 1}, {"x3", 0, 1}};
    std::vector<Observation> history;
    for (const auto& x : std::vector<std::vector<double>>{{0.8, 0.2, 0.5}, {0.7, 0.7, 0.1}, {0.9, 0.5, 0.9},
                                                          {0.65, 0.9, 0.3}, {0.9, 0.9, 0.6}, {0.75, 0.1, 0.2}})
        history.push_back({x, 0.0, false, ""});
    for (double a : {0.1, 0.25, 0.4})
        for (double b : {0.1, 0.25, 0.4}) history.push_back({{a, b, 0.2}, 1.0 + a + b, false, ""});
    OptimizerOptions o = fast_options(1);
    o.direction = Direction::maximize;
    o.initial_points = 6;
    o.dead_value = 0.0;
    Optimizer opt(specs, o, history);
    EXPECT_TRUE(opt.live_probability({{0.25, 0.25, 0.2}}).empty());  // not fitted before an ask
    opt.ask(1);
    const std::vector<double> p = opt.live_probability({{0.25, 0.25, 0.2}, {0.25, 0.25, 0.95}, {0.85, 0.5, 0.5}});
    ASSERT_EQ(p.size(), 3u);
    EXPECT_GT(p[0], 0.95);  // inside the live cluster
    EXPECT_LT(p[1], 0.9);   // far along x3: less sure than inside (fitted freely: 0.977 as inside)
    EXPECT_LT(p[2], 0.1);   // among the dead
}

TEST(OptimizerTest, FindsBraninMinimum) {
    const TestFunction fn = branin();
    Optimizer opt(fn.space, fast_options(1));
    run(opt, fn, 40, 1);
    ASSERT_TRUE(opt.best().has_value());
    EXPECT_LT(opt.best()->value - fn.minimum, 0.05);
}

TEST(OptimizerTest, CopulaWarpingRunsAndImproves) {
    const TestFunction fn = branin();
    OptimizerOptions o = fast_options(11);
    o.warping = OutputWarping::copula;
    Optimizer opt(fn.space, o);
    run(opt, fn, 30, 2);
    EXPECT_LT(opt.best()->value - fn.minimum, 1.0);
}

TEST(OptimizerTest, StartPointsComeFirstThenDesignThenModel) {
    const TestFunction fn = hartmann6();
    Optimizer opt(fn.space, fast_options(2));
    const std::vector<double> baseline = {0.2, 0.15, 0.48, 0.28, 0.31, 0.66};
    opt.add_start_point(baseline);
    const auto first = opt.ask(1);
    EXPECT_EQ(first[0].origin, "start");
    EXPECT_EQ(first[0].values, baseline);
    opt.tell(first[0].id, fn.f(first[0].values));
    const auto design = opt.ask(opt.initial_points() - 1);
    for (const auto& p : design) {
        EXPECT_EQ(p.origin, "initial");
        opt.tell(p.id, fn.f(p.values));
    }
    EXPECT_EQ(opt.ask(1)[0].origin, "model");
}

TEST(OptimizerTest, BatchesNeverDuplicateOnSmallIntegerSpace) {
    // 4 × 4 = 16 possible points; 16 proposals must be exactly all of them.
    const std::vector<ParameterSpec> specs = {{"a", 0, 3, true}, {"b", 1, 4, true}};
    Optimizer opt(specs, fast_options(3));
    std::set<std::vector<double>> seen;
    for (int round = 0; round < 4; ++round) {
        const auto props = opt.ask(4);
        ASSERT_EQ(props.size(), 4u);
        for (const auto& p : props) {
            EXPECT_TRUE(seen.insert(p.values).second) << p.values[0] << "," << p.values[1];
            for (double v : p.values) EXPECT_EQ(v, std::round(v));
            opt.tell(p.id, (p.values[0] - 2) * (p.values[0] - 2) + p.values[1]);
        }
    }
    EXPECT_EQ(seen.size(), 16u);
    EXPECT_EQ(opt.ask(2).size(), 2u);  // exhausted space still answers
}

// A flat objective on a coarse float grid (every set scores the same, as a dead region does):
// the proposals never repeat a grid point, so no evaluation is spent twice.
TEST(OptimizerTest, SteppedFloatsAreNeverProposedTwice) {
    const std::vector<ParameterSpec> specs = {{"a", 0.0, 1.0, false, false, 0.1}, {"b", 0.0, 0.5, false, false, 0.1}};
    OptimizerOptions o = fast_options(5);
    Optimizer opt(specs, o);
    std::set<std::pair<long, long>> seen;
    for (int i = 0; i < 40; ++i) {
        const auto p = opt.ask(1).at(0);
        const long a = std::lround(p.values[0] * 10), b = std::lround(p.values[1] * 10);
        EXPECT_NEAR(p.values[0] * 10, static_cast<double>(a), 1e-9);
        EXPECT_TRUE(seen.insert({a, b}).second) << "proposal " << i << " repeats " << p.values[0] << "," << p.values[1];
        opt.tell(p.id, 1.0);
    }
}

TEST(OptimizerTest, PendingPointsAreAccountedForAcrossAsks) {
    const TestFunction fn = branin();
    Optimizer opt(fn.space, fast_options(4));
    run(opt, fn, 10, 5);
    // Asynchronous: three separate asks without any tell in between, then a batch of 8.
    std::vector<Proposal> pending;
    for (int i = 0; i < 3; ++i) pending.push_back(opt.ask(1)[0]);
    for (const auto& p : opt.ask(8)) pending.push_back(p);
    EXPECT_EQ(opt.pending(), 11u);
    const SearchSpace& space = opt.space();
    for (std::size_t i = 0; i < pending.size(); ++i) {
        for (std::size_t j = i + 1; j < pending.size(); ++j) {
            const double dist =
                (space.from_values(pending[i].values) - space.from_values(pending[j].values))
                    .norm();
            EXPECT_GT(dist, 1e-3) << i << " " << j;
        }
    }
}

TEST(OptimizerTest, FailedRegionIsAvoided) {
    // Everything with x1 > 0.6 (unit cube) "crashes the matcher".
    const std::vector<ParameterSpec> specs = {{"x1", 0, 1}, {"x2", 0, 1}};
    OptimizerOptions o = fast_options(5);
    o.direction = Direction::maximize;
    Optimizer opt(specs, o);
    int failures_after_design = 0;
    for (int i = 0; i < 40; ++i) {
        const Proposal p = opt.ask(1)[0];
        if (p.values[0] > 0.6) {
            // The objective increases towards the failing region, a worst case for avoidance.
            if (p.origin == "model" || p.origin == "quadratic") ++failures_after_design;
            opt.tell_failed(p.id, "crash");
        } else {
            opt.tell(p.id, p.values[0] - (p.values[1] - 0.5) * (p.values[1] - 0.5));
        }
    }
    // Probing the boundary costs a few failures, not a stream of them.
    EXPECT_LE(failures_after_design, 8);
    EXPECT_FALSE(opt.tell(12345, 1.0));  // unknown id
    ASSERT_TRUE(opt.best().has_value());
    EXPECT_GT(opt.best()->values[0], 0.5);
    const auto& obs = opt.observations();
    for (std::size_t i = 0; i < obs.size(); ++i) {
        for (std::size_t j = 0; j < i; ++j) {
            if (!obs[j].failed) continue;
            const double dx = obs[i].values[0] - obs[j].values[0];
            const double dy = obs[i].values[1] - obs[j].values[1];
            EXPECT_GE(std::sqrt(dx * dx + dy * dy), o.failure_radius - 1e-9);
        }
    }
}

TEST(OptimizerTest, RestoresFromObservations) {
    const TestFunction fn = hartmann6();
    Optimizer a(fn.space, fast_options(7));
    run(a, fn, 25, 1);
    Optimizer b(fn.space, fast_options(7), a.observations());
    EXPECT_EQ(b.observations().size(), 25u);
    EXPECT_EQ(b.best()->value, a.best()->value);
    const Proposal p = b.ask(1)[0];
    EXPECT_EQ(p.origin, "model");
    for (const auto& o : a.observations()) EXPECT_NE(o.values, p.values);
    // A restored optimizer given the same history proposes the same point.
    Optimizer c(fn.space, fast_options(7), a.observations());
    EXPECT_EQ(c.ask(1)[0].values, p.values);
}

TEST(OptimizerTest, TellIsSingleUseAndCancelWithdraws) {
    const TestFunction fn = branin();
    Optimizer opt(fn.space, fast_options(8));
    const auto p = opt.ask(2);
    EXPECT_TRUE(opt.tell(p[0].id, 1.0));
    EXPECT_FALSE(opt.tell(p[0].id, 1.0));
    EXPECT_TRUE(opt.cancel(p[1].id));
    EXPECT_FALSE(opt.tell_failed(p[1].id, "late"));
    EXPECT_EQ(opt.pending(), 0u);
    EXPECT_EQ(opt.observations().size(), 1u);
}

TEST(OptimizerTest, MixedIntegerLogSpaceProposalsStayValid) {
    const std::vector<ParameterSpec> specs = {
        {"r", 0.1, 2.0, false, true}, {"n", 3, 300, true, true}, {"t", 0.0, 1.0}};
    OptimizerOptions o = fast_options(9);
    o.direction = Direction::maximize;
    Optimizer opt(specs, o);
    for (int i = 0; i < 20; ++i) {
        for (const Proposal& p : opt.ask(2)) {
            EXPECT_GE(p.values[0], 0.1);
            EXPECT_LE(p.values[0], 2.0);
            EXPECT_EQ(p.values[1], std::round(p.values[1]));
            EXPECT_GE(p.values[1], 3.0);
            EXPECT_LE(p.values[1], 300.0);
            opt.tell(p.id, -std::pow(std::log(p.values[0] / 0.5), 2) -
                               std::pow(std::log(p.values[1] / 40.0), 2) - p.values[2]);
        }
    }
    EXPECT_GT(opt.best()->value, -0.5);
}

}  // namespace
}  // namespace maptune::bo

namespace maptune::bo {
namespace {

// Multi-fidelity (issue 16): a proposal stopped on a subset enters as an estimate. The model
// learns a noise for such values and never predicts one of them as the best, even when its
// estimate is the highest value seen.
TEST(OptimizerTest, LowFidelityEstimatesAreNoisyAndNeverThePredictedBest) {
    Optimizer opt({{"x", 0.0, 1.0}, {"y", 0.0, 1.0}}, OptimizerOptions{});
    auto f = [](double x, double y) { return std::exp(-8 * ((x - 0.3) * (x - 0.3) + (y - 0.6) * (y - 0.6))); };
    for (int i = 0; i < 16; ++i) {
        const auto p = opt.ask(1).front();
        opt.tell(p.id, f(p.values[0], p.values[1]));
    }
    // Estimates that stray by ±0.3, one of them above every measured value.
    for (int i = 0; i < 12; ++i) {
        const double x = 0.05 + 0.075 * i, y = 0.9 - 0.07 * i;
        Observation o;
        o.values = {x, y};
        o.value = f(x, y) + (i % 2 == 0 ? 0.3 : -0.3);
        o.low_fidelity = true;
        opt.add_observation(o);
    }
    Observation top;
    top.values = {0.31, 0.59};
    top.value = 1.5;
    top.low_fidelity = true;
    opt.add_observation(top);
    opt.fit();
    EXPECT_GT(opt.hyperparameters().low_fidelity_noise, 10.0 * opt.hyperparameters().noise_variance);
    const auto pb = opt.predicted_best();
    ASSERT_TRUE(pb.has_value());
    EXPECT_FALSE(pb->values[0] == 0.31 && pb->values[1] == 0.59);
    EXPECT_LT(pb->mean, 1.2);
    // Rebuilt from the same observations, the model is the same.
    Optimizer again({{"x", 0.0, 1.0}, {"y", 0.0, 1.0}}, OptimizerOptions{});
    std::vector<std::string> origins(opt.observations().size(), "model");
    for (std::size_t i = 0; i < 16; ++i) origins[i] = i < static_cast<std::size_t>(opt.initial_points()) ? "initial" : "model";
    again.replay(opt.observations(), origins);
    again.fit();
    const auto pb2 = again.predicted_best();
    ASSERT_TRUE(pb2.has_value());
    EXPECT_EQ(pb2->values, pb->values);
}

TEST(OptimizerTest, PredictedBestIsTheObservationWithTheHighestPosteriorMean) {
    // Maximize a smooth 1-D bump; noise-free observations: the model agrees with the data.
    Optimizer opt({{"x", 0.0, 1.0}}, OptimizerOptions{});
    EXPECT_FALSE(opt.predicted_best().has_value());
    for (int i = 0; i < 12; ++i) {
        const auto p = opt.ask(1).front();
        const double x = p.values[0];
        opt.tell(p.id, std::exp(-50 * (x - 0.3) * (x - 0.3)));
    }
    const auto pb = opt.predicted_best();
    ASSERT_TRUE(pb.has_value());
    const auto best = opt.best();
    ASSERT_TRUE(best.has_value());
    EXPECT_NEAR(pb->values[0], best->values[0], 0.05);
    EXPECT_NEAR(pb->mean, best->value, 0.05);
    EXPECT_GE(pb->std, 0.0);
    EXPECT_LT(pb->std, 0.2);
}

}  // namespace
}  // namespace maptune::bo
