#pragma once
// Output of a comparison (`maptune compare`, `maptune validate`, the end of `maptune run`):
// the Table 5.2 layout as markdown, text table, CSV or JSON, and the notes on every view.
#ifdef MAPTUNE_HAVE_EVALUATION
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>

#include "evaluation/compare.hpp"
#include "table.hpp"

namespace maptune::cli {

// One row per set; per view p (and p minus the baseline's when `baseline_row` >= 0), m, eps,
// median errors, the reference score; a kendall_tau row when any view has one.
Table compare_table(const evaluation::CompareResult& r, int baseline_row = -1);
nlohmann::json compare_json(const evaluation::CompareResult& r);
// Per view: dataset, pairs, m* and its rule, what was evaluated and what came from the store.
void write_compare_notes(std::ostream& out, const evaluation::CompareResult& r, bool markdown);
// format: markdown | table | csv | json.
void write_compare(std::ostream& out, const evaluation::CompareResult& r, const std::string& format,
                   int baseline_row = -1);

}  // namespace maptune::cli
#endif
