#pragma once
// Writing a report (`maptune report`, and the end of `maptune run`).
#ifdef MAPTUNE_HAVE_REPORT
#include <filesystem>
#include <string>
#include <vector>

#include "report/report_data.hpp"

namespace maptune::cli {

// Gathers the data of `run_dirs` into <out>/report-data.json and renders <out>/index.html and
// <out>/figures/*.svg (tools/report under Node.js); the page reloads itself every `refresh_s`
// seconds while a run is still going (0: never). Returns whether one is. Throws
// params::ConfigError naming what is missing (a run file, Node.js, the renderer's packages).
bool write_report(const std::vector<std::string>& run_dirs, const std::filesystem::path& out,
                  const report::ReportOptions& options, double refresh_s);

}  // namespace maptune::cli
#endif
