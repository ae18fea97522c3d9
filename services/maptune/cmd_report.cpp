// maptune report: a self-contained HTML report and SVG figures of one or more runs (issue 11).
// The data (trials, the refitted GP, per-pair errors, validation) comes from libs/report; the
// figures are drawn by tools/report/render.mjs with Vega-Lite under Node.js.
#ifdef MAPTUNE_HAVE_REPORT
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>

#include "commands.hpp"
#include "params/cli_range.hpp"
#include "dataset/io.hpp"
#include "params/parameter_space.hpp"
#include "params/yaml_util.hpp"
#include "experiment/run_files.hpp"
#include "report_cli.hpp"
#ifdef MAPTUNE_HAVE_SERVICES
#include "runtime.hpp"
#endif

extern char** environ;

namespace maptune::cli {
namespace {

namespace fs = std::filesystem;

struct ReportCliOptions {
    std::vector<std::string> run_dirs;
    std::string out;
    report::ReportOptions data;
    std::vector<std::string> grid;
    bool follow = false;
    double interval_s = 5;
};

fs::path tools_dir() {
    if (const char* env = std::getenv("MAPTUNE_REPORT_TOOLS"); env && *env) return env;
    return MAPTUNE_REPORT_TOOLS_DIR;
}

// Runs `node render.mjs DATA OUT [--refresh S]`; throws with what to install when it cannot.
void render(const fs::path& data_file, const fs::path& out, double refresh_s) {
    const fs::path tools = tools_dir();
    if (!fs::exists(tools / "render.mjs") || !fs::exists(tools / "node_modules" / "vega-lite")) {
        throw params::ConfigError(tools.string() + ": no render.mjs with node_modules (run `bash scripts/install-deps.sh`, "
                                  "or set MAPTUNE_REPORT_TOOLS to a tools/report directory with `npm ci` done)");
    }
    std::vector<std::string> args{"node", (tools / "render.mjs").string(), data_file.string(), out.string()};
    if (refresh_s > 0) {
        args.push_back("--refresh");
        args.push_back(params::format_fixed(refresh_s, 0));
    }
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    if (posix_spawnp(&pid, "node", nullptr, nullptr, argv.data(), environ) != 0) {
        throw params::ConfigError("cannot start node (Node.js): install it with `bash scripts/install-deps.sh`");
    }
    int status = 0;
    waitpid(pid, &status, 0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        throw params::ConfigError("node " + (tools / "render.mjs").string() + " failed (exit " +
                                  std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
    }
}

// What a re-render depends on: the run files' modification times.
std::string signature(const std::vector<std::string>& run_dirs) {
    std::string s;
    std::vector<fs::path> dirs(run_dirs.begin(), run_dirs.end());
    std::vector<fs::path> expanded;
    try {
        expanded = experiment::expand_run_dirs(dirs);
    } catch (const std::exception&) {
        return s;  // not there yet
    }
    for (const auto& d : expanded) {
        for (const char* f : {"run.yaml", "trials.csv", "validation.csv", "predicted_best.yaml"}) {
            std::error_code ec;
            const auto t = fs::last_write_time(d / f, ec);
            s += d.string() + f + (ec ? "-" : std::to_string(t.time_since_epoch().count())) + ";";
        }
    }
    return s;
}

}  // namespace

bool write_report(const std::vector<std::string>& run_dirs, const fs::path& out, const report::ReportOptions& options,
                  double refresh_s) {
    const std::vector<fs::path> dirs(run_dirs.begin(), run_dirs.end());
    const auto data = report::report_data(dirs, options);
    bool running = false;
    for (const auto& run : data["runs"]) running |= run["record"].value("state", "") == "running";
    fs::create_directories(out);
    const fs::path data_file = out / "report-data.json";
    dataset::write_file(data_file, data.dump());
    render(data_file, out, running ? refresh_s : 0);
    return running;
}

void add_report_command(CLI::App& app, int& exit_code) {
    auto opt = std::make_shared<ReportCliOptions>();
    auto* cmd = app.add_subcommand(
        "report",
        "HTML report (self-contained, opens offline) and SVG figures of one or more runs: history with "
        "best so far and baseline, the four-panel best-so-far figure, errors of baseline vs best, GP slices, "
        "a 2-D grid, parallel coordinates, importance, validation and run metadata.");
    cmd->add_option("run_dirs", opt->run_dirs,
                    "run directories (a repeated run's directory stands for all its seed-* runs)")
        ->required();
    cmd->add_option("-o,--out", opt->out, "output directory (default: <first run dir>/report)");
    cmd->add_option("--db", opt->data.db, "observation store (default: the run's observations.db, or its parent's)");
    cmd->add_option("--experiment", opt->data.experiment, "experiment YAML (default: the one in each run.yaml)");
    cmd->add_option("--grid", opt->grid, "the two parameters of the 2-D grid, X,Y (default: shortest length scales)")
        ->delimiter(',')
        ->expected(2);
    cmd->add_option("--grid-points", opt->data.grid_points, "grid points per axis, 5..100")
        ->check(CLI::Range(5, 100))
        ->capture_default_str();
    cmd->add_flag("--follow", opt->follow,
                  "keep re-rendering as observations arrive (the page reloads itself while a run goes on); "
                  "ends when every run has finished, or on Ctrl-C");
    cmd->add_option("--interval", opt->interval_s, "seconds between checks and page reloads with --follow, 1..3600")
        ->check(maptune::params::finite_range(1.0, 3600.0))
        ->capture_default_str();
    cmd->callback([opt, &exit_code] {
        if (opt->grid.size() == 2) {
            opt->data.grid_x = opt->grid[0];
            opt->data.grid_y = opt->grid[1];
        }
        const fs::path out = opt->out.empty() ? fs::path(opt->run_dirs.front()) / "report" : fs::path(opt->out);
        try {
            if (!opt->follow) {
                const auto t0 = std::chrono::steady_clock::now();
                write_report(opt->run_dirs, out, opt->data, 0);
                const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                std::cout << "report written in " << params::format_fixed(s, 1) << " s: open "
                          << (out / "index.html").string() << "\n";
                return;
            }
#ifdef MAPTUNE_HAVE_SERVICES
            services::install_stop_signals();
            std::string last;
            std::cout << "following " << opt->run_dirs.front() << (opt->run_dirs.size() > 1 ? " ..." : "")
                      << "; open " << (out / "index.html").string() << " (Ctrl-C stops)" << std::endl;
            while (!services::stop_requested()) {
                const std::string now = signature(opt->run_dirs);
                if (!now.empty() && now != last) {
                    last = now;
                    if (!write_report(opt->run_dirs, out, opt->data, opt->interval_s)) {
                        std::cout << "every run has finished; final report in " << (out / "index.html").string() << "\n";
                        return;
                    }
                }
                const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(opt->interval_s);
                while (!services::stop_requested() && std::chrono::steady_clock::now() < until) {
                    std::this_thread::sleep_for(std::chrono::milliseconds(100));
                }
            }
#else
            throw params::ConfigError("--follow needs the services build");
#endif
        } catch (const std::exception& e) {
            std::cerr << "maptune report: " << e.what() << "\n";
            exit_code = 2;
        }
    });
}

}  // namespace maptune::cli
#endif
