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
    // The reference matcher's space as shipped (MAPTUNE_SPACE_FILE: set by fuzz/CMakeLists.txt).
    static const auto s = maptune::params::ParameterSpace::load(MAPTUNE_SPACE_FILE);
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
