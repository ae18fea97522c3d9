#pragma once
// Temporary directories and tiny simulated datasets for test suites: the one fixture the
// evaluation, scoring and compare tests share (header-only; link maptune::dataset).

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "dataset/simulator.hpp"

namespace maptune::test {

// A fresh directory /tmp/<prefix>XXXXXX; the caller removes it.
inline std::filesystem::path make_temp_dir(const std::string& prefix) {
    std::string tmpl = (std::filesystem::temp_directory_path() / (prefix + "XXXXXX")).string();
    if (mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed for " + tmpl);
    return tmpl;
}

// Generates `preset` with `runs` x `submaps` into root/name and returns that path.
inline std::filesystem::path generate_tiny_dataset(const std::filesystem::path& root, const std::string& name,
                                                   int runs, int submaps, std::uint64_t seed = 1,
                                                   const std::string& preset = "lab-tiny") {
    auto c = dataset::sim_preset(preset);
    c.runs = runs;
    c.submaps = submaps;
    c.seed = seed;
    dataset::generate_dataset(c, root / name);
    return root / name;
}

}  // namespace maptune::test
