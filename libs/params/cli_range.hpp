#pragma once
// A CLI11 check for floating-point options: CLI::Range lets NaN through (every comparison with
// it is false), so `--wait nan` or `--pair-time-limit nan` passed. Header-only, for the
// command-line front-ends that already use CLI11.

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>

namespace maptune::params {

// A finite number in [lo, hi].
inline CLI::Validator finite_range(double lo, double hi) {
    std::ostringstream desc;
    desc << "FLOAT in [" << lo << " - " << hi << "]";
    return CLI::Validator(
        [lo, hi](std::string& text) -> std::string {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (end == text.c_str() || *end != '\0' || !std::isfinite(v) || v < lo || v > hi) {
                std::ostringstream msg;
                msg << "'" << text << "' is not a finite number in [" << lo << ", " << hi << "]";
                return msg.str();
            }
            return "";
        },
        desc.str());
}

}  // namespace maptune::params
