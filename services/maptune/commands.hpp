#pragma once
// Subcommands of the maptune CLI. Each add_*_command registers its options on `app` and
// returns; the callback runs the command and sets `exit_code` (0 ok, 1 failure, 2 bad input).

#include <CLI/CLI.hpp>

namespace maptune::cli {

void add_score_command(CLI::App& app, int& exit_code);
void add_trials_command(CLI::App& app, int& exit_code);
void add_params_command(CLI::App& app, int& exit_code);
#ifdef MAPTUNE_HAVE_BO
void add_bo_bench_command(CLI::App& app, int& exit_code);
#endif
#ifdef MAPTUNE_HAVE_TUNING
void add_optimize_command(CLI::App& app, int& exit_code);
#endif
#ifdef MAPTUNE_HAVE_SERVICES
void add_run_command(CLI::App& app, int& exit_code);
void add_watch_command(CLI::App& app, int& exit_code);
#endif
#ifdef MAPTUNE_HAVE_EVALUATION
void add_evaluate_command(CLI::App& app, int& exit_code);
void add_sweep_command(CLI::App& app, int& exit_code);
void add_compare_command(CLI::App& app, int& exit_code);
void add_validate_command(CLI::App& app, int& exit_code);
#endif
#ifdef MAPTUNE_HAVE_REPORT
void add_report_command(CLI::App& app, int& exit_code);
#endif
#ifdef MAPTUNE_HAVE_DATASET
void add_dataset_command(CLI::App& app, int& exit_code);
#endif

}  // namespace maptune::cli
