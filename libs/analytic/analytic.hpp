#pragma once
// A test objective with the matcher's contract and no PCL: estimates are the reference
// transform moved by an error that depends smoothly on the parameters (best near `optimum`,
// in the unit cube of the space), matches are drawn with a parameter-dependent probability.
// Deterministic per (parameters, pair): every worker that runs it — maptune's own or a
// plug-in on another DDS implementation — gives the same observation.

#include <optional>
#include <string>
#include <vector>

#include "dataset/dataset.hpp"
#include "params/parameter_space.hpp"
#include "store/observation_store.hpp"

namespace maptune::analytic {

// Uniform in [0, 1) from a string (FNV-1a), stable across platforms.
double unit_hash(const std::string& text);

// The default optimum: one unit-cube coordinate per parameter of the space, in [0.3, 0.7].
std::vector<double> default_optimum(std::size_t dimensions);

// Quality in [0, 1] of a full parameter set: 1 at the optimum, ~0.37 at unit-cube distance 0.5.
double quality(const params::ParameterSpace& space, const std::vector<double>& optimum,
               const params::ParameterSet& params);

// The answer for `pair_ids` ("idA|idB", complete-view pairs of `dataset`) under a full rounded
// set; nullopt with `error` naming the pair when one is not in the dataset.
std::optional<std::vector<store::PairRecord>> evaluate(const dataset::Dataset& dataset,
                                                       const params::ParameterSpace& space,
                                                       const std::vector<double>& optimum,
                                                       const params::ParameterSet& params,
                                                       const std::vector<std::string>& pair_ids,
                                                       double duration_s, std::string* error);

}  // namespace maptune::analytic
