// maptune: tunes the parameters of feature-based 3D map matchers by Bayesian optimization.
#include <iostream>

#include "commands.hpp"
#ifdef MAPTUNE_HAVE_SERVICES
#include "runtime.hpp"
#endif

int main(int argc, char** argv) {
#ifdef MAPTUNE_HAVE_SERVICES
    maptune::services::bound_malloc_arenas();  // the matcher runs in this process too
#endif
    CLI::App app{"maptune — Bayesian tuning of 3D map matcher parameters"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "maptune 0.1.0");
    int exit_code = 0;
    maptune::cli::add_score_command(app, exit_code);
    maptune::cli::add_trials_command(app, exit_code);
    maptune::cli::add_params_command(app, exit_code);
#ifdef MAPTUNE_HAVE_BO
    maptune::cli::add_bo_bench_command(app, exit_code);
#endif
#ifdef MAPTUNE_HAVE_TUNING
    maptune::cli::add_optimize_command(app, exit_code);
#endif
#ifdef MAPTUNE_HAVE_SERVICES
    maptune::cli::add_run_command(app, exit_code);
    maptune::cli::add_watch_command(app, exit_code);
#endif
#ifdef MAPTUNE_HAVE_EVALUATION
    maptune::cli::add_evaluate_command(app, exit_code);
    maptune::cli::add_sweep_command(app, exit_code);
    maptune::cli::add_compare_command(app, exit_code);
    maptune::cli::add_validate_command(app, exit_code);
#endif
#ifdef MAPTUNE_HAVE_REPORT
    maptune::cli::add_report_command(app, exit_code);
#endif
#ifdef MAPTUNE_HAVE_DATASET
    maptune::cli::add_dataset_command(app, exit_code);
#endif
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;
    } catch (const std::exception& e) {
        // Last line of defence: a filesystem or library error a command did not catch (a run
        // directory under a file, a dataset path in a symlink loop) ends with its message,
        // never with std::terminate.
        std::cerr << "maptune: " << e.what() << "\n";
        return 1;
    }
    return exit_code;
}
