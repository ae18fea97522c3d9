// YAML and CSV inputs a user or another tool writes: the first byte picks a design space, a
// parameter set (checked against the reference matcher's space), an experiment file, a
// dataset manifest or a run's trials.csv.
#include <exception>
#include <string>

#include "dataset/dataset.hpp"
#include "experiment/experiment.hpp"
#include "experiment/run_files.hpp"
#include "fuzz_util.hpp"
#include "params/parameter_set.hpp"
#include "params/parameter_space.hpp"

namespace {

const maptune::params::ParameterSpace& space() {
    static const auto s = maptune::params::ParameterSpace::parse(R"(name: lru_matcher
parameters:
  r_N:   {type: float, low: 0.1,  high: 2.0, default: 0.2}
  v_K:   {type: float, low: 0.05, high: 0.5, default: 0.1}
  t_K:   {type: float, low: 0.0,  high: 1.0, default: 1.0}
  r_D:   {type: float, low: 0.1,  high: 2.0, default: 0.2}
  n_C:   {type: int,   low: 1,    high: 10,  default: 3}
  t_C:   {type: float, low: 0.0,  high: 1.0, default: 0.5}
  r_LRF: {type: float, low: 0.1,  high: 1.0, default: 0.2}
  v_TF:  {type: float, low: 0.1,  high: 1.0, default: 0.5}
  n_TF:  {type: int,   low: 3,    high: 300, default: 8}
)", "fuzz space");
    return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
    namespace fs = std::filesystem;
    try {
        switch (data[0] % 5) {
            case 0: (void)maptune::params::ParameterSpace::parse(text, "fuzz.yaml"); break;
            case 1: (void)maptune::params::parse_parameter_set(text, "fuzz.yaml", space()); break;
            case 2:
                (void)maptune::experiment::load_experiment(
                    maptune::fuzz::write_input("experiment.yaml", data + 1, size - 1).string());
                break;
            case 3: {
                const fs::path dir = maptune::fuzz::scratch_dir() / "dataset";
                fs::create_directories(dir);
                maptune::fuzz::write_input("dataset/manifest.yaml", data + 1, size - 1);
                (void)maptune::dataset::Dataset::open(dir);
                break;
            }
            default:
                (void)maptune::experiment::read_trials_csv(
                    maptune::fuzz::write_input("trials.csv", data + 1, size - 1), space());
        }
    } catch (const std::exception&) {
    }
    return 0;
}
