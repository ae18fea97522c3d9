#include "run_directory.hpp"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <random>

#include <yaml-cpp/yaml.h>

#include "dataset/io.hpp"
#include "experiment/run_files.hpp"
#include "params/export.hpp"
#include "params/yaml_util.hpp"

namespace maptune::tuning {

namespace fs = std::filesystem;

namespace {
std::string fmt(double v, int decimals = 4) { return params::format_fixed(v, decimals); }
// Shortest text that reads back as the same double (YAML's own emitter writes 17 digits).
std::string num(double v) { return params::format_double(v); }
}  // namespace

double now_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string utc_now(const char* format) {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[64];
    std::strftime(buf, sizeof(buf), format, &tm);
    return buf;
}

std::string new_incarnation_id() {
    std::random_device rd;
    const std::uint64_t bits = (static_cast<std::uint64_t>(rd()) << 32) ^ rd() ^
                               static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
    char buf[16];
    std::snprintf(buf, sizeof(buf), "%012llx", static_cast<unsigned long long>(bits & 0xffffffffffffULL));
    return buf;
}

RunDirectory::RunDirectory(fs::path dir, const experiment::Experiment& experiment, RunInfo info)
    : dir_(std::move(dir)), experiment_(experiment), info_(std::move(info)) {
    fs::create_directories(dir_);
    std::error_code ec;
    if (!fs::exists(dir_ / "run.yaml", ec)) return;
    std::string recorded;
    try {
        recorded = experiment::read_run_record(dir_).space_hash;
    } catch (const params::ConfigError&) {
        return;  // a broken record is reported where the run is read
    }
    const std::string now = experiment_.space.hash();
    if (!recorded.empty() && recorded != now) {
        space_change_ = (dir_ / "run.yaml").string() + ": the run started in another design space (space hash " +
                        recorded + ", now " + now + " from " + experiment_.space.name() +
                        "): its evaluations resume as parameter values in the current space";
    }
}

void RunDirectory::write_results(const RunSummary& summary) const {
    const auto& e = experiment_;
    dataset::write_file(dir_ / "trials.csv", experiment::trials_csv(summary.evaluations, e.space));
    if (summary.best >= 0) {
        const auto& b = summary.evaluations[static_cast<std::size_t>(summary.best)];
        const std::string header =
            "best of experiment " + info_.experiment_id + ": " +
            (e.objective ? "value = " + num(b.p) : "p = " + fmt(b.p) + ", m = " + std::to_string(b.m)) +
            " (evaluation " + std::to_string(b.number) + ")";
        dataset::write_file(dir_ / "best_params.yaml", params::to_plain_yaml(b.params, e.space, header));
        dataset::write_file(dir_ / "best_params.ros2.yaml",
                            "# " + header + "\n" + params::to_ros2_yaml(b.params, e.space, "map_matcher"));
    }
    if (summary.predicted_best) {
        const std::string header = "predicted best of experiment " + info_.experiment_id + " (GP posterior mean " +
                                   fmt(summary.predicted_mean) + " +- " + fmt(summary.predicted_std) + " after " +
                                   std::to_string(summary.evaluations.size()) + " evaluations)";
        dataset::write_file(dir_ / "predicted_best.yaml",
                            params::to_plain_yaml(e.space.round(*summary.predicted_best), e.space, header));
    }
}

void RunDirectory::append_hyperparameters(int evaluation, const gp::Hyperparameters& hp) const {
    const auto& names = experiment_.optimize;
    if (hp.length_scales.size() != static_cast<Eigen::Index>(names.size())) return;  // no fit yet
    const fs::path file = dir_ / "gp_hyperparameters.csv";
    std::error_code ec;
    const bool fresh = !fs::exists(file, ec) || fs::file_size(file, ec) == 0;
    std::ofstream out(file, std::ios::app);
    // Multi-fidelity runs also record the extra noise of the subset's estimates (the column
    // depends on the experiment only, so a resumed run keeps the header it started with).
    const bool low_fidelity = experiment_.multi_fidelity();
    if (fresh) {
        out << "evaluation,signal_variance,noise_variance";
        for (const auto& name : names) out << ",length_scale_" << name;
        if (low_fidelity) out << ",low_fidelity_noise";
        out << "\n";
    }
    out << evaluation << "," << params::format_double(hp.signal_variance) << ","
        << params::format_double(hp.noise_variance);
    for (Eigen::Index i = 0; i < hp.length_scales.size(); ++i) out << "," << params::format_double(hp.length_scales(i));
    if (low_fidelity) out << "," << params::format_double(hp.low_fidelity_noise);
    out << "\n";
}

void RunDirectory::write_record(const RunSummary& summary, const std::optional<RunEnd>& end) const {
    const auto& e = experiment_;
    YAML::Emitter out;
    out << YAML::BeginMap;
    out << YAML::Key << "experiment" << YAML::Value << e.name;
    out << YAML::Key << "experiment_id" << YAML::Value << info_.experiment_id;
    std::error_code ec;
    const fs::path file = e.file.empty() ? fs::path() : fs::absolute(e.file, ec).lexically_normal();
    out << YAML::Key << "experiment_file" << YAML::Value << file.string();
    out << YAML::Key << "space" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << e.space.name();
    out << YAML::Key << "hash" << YAML::Value << e.space.hash();
    out << YAML::EndMap;
    if (e.objective) {
        out << YAML::Key << "objective" << YAML::Value << YAML::BeginMap;
        out << YAML::Key << "command" << YAML::Value << e.objective->command;
        out << YAML::Key << "direction" << YAML::Value << (e.minimize ? "minimize" : "maximize");
        out << YAML::Key << "timeout_s" << YAML::Value << num(e.objective->timeout_s);
        out << YAML::Key << "parallel" << YAML::Value << e.objective->parallel;
        out << YAML::EndMap;
    } else {
        out << YAML::Key << "dataset" << YAML::Value << YAML::BeginMap;
        out << YAML::Key << "dir" << YAML::Value << fs::absolute(e.dataset_dir, ec).lexically_normal().string();
        out << YAML::Key << "id" << YAML::Value << info_.dataset_id;
        out << YAML::Key << "name" << YAML::Value << info_.dataset_name;
        out << YAML::Key << "view" << YAML::Value << e.view;
        out << YAML::Key << "reference" << YAML::Value << e.reference;
        out << YAML::EndMap;
        out << YAML::Key << "measure" << YAML::Value << YAML::BeginMap;
        out << YAML::Key << "e_star" << YAML::Value << num(e.e_star);
        out << YAML::Key << "m_star" << YAML::Value << num(summary.m_star);
        out << YAML::Key << "m_star_rule" << YAML::Value << (e.m_star ? "given" : e.m_star_per_pair ? "per_pair" : "auto");
        out << YAML::Key << "w_v" << YAML::Value << num(e.w_v);
        out << YAML::EndMap;
        out << YAML::Key << "matcher" << YAML::Value << YAML::BeginMap;
        out << YAML::Key << "id" << YAML::Value << info_.matcher_id;
        out << YAML::Key << "version" << YAML::Value << info_.matcher_version;
        out << YAML::EndMap;
    }
    out << YAML::Key << "optimizer" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "acquisition" << YAML::Value << e.acquisition;
    out << YAML::Key << "seed" << YAML::Value << e.seed;
    out << YAML::Key << "warping" << YAML::Value << e.warping;
    out << YAML::Key << "search" << YAML::Value << e.search;
    out << YAML::Key << "cholesky" << YAML::Value << e.cholesky;
    out << YAML::Key << "optimize" << YAML::Value << YAML::Flow << e.optimize;
    out << YAML::EndMap;
    out << YAML::Key << "budget" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "evaluations" << YAML::Value << e.max_evaluations;
    out << YAML::Key << "seconds" << YAML::Value << num(e.max_seconds);
    out << YAML::EndMap;
    out << YAML::Key << "started_utc" << YAML::Value << info_.started_utc;
    out << YAML::Key << "state" << YAML::Value << (end ? "finished" : "running");
    if (end) {
        out << YAML::Key << "finished_utc" << YAML::Value << end->finished_utc;
        out << YAML::Key << "wall_s" << YAML::Value << fmt(end->wall_s, 1);
        out << YAML::Key << "stop_reason" << YAML::Value << summary.stop_reason;
        out << YAML::Key << "evaluations" << YAML::Value << summary.evaluations.size();
        if (summary.best >= 0) {
            const auto& b = summary.evaluations[static_cast<std::size_t>(summary.best)];
            out << YAML::Key << "best" << YAML::Value << YAML::BeginMap;
            out << YAML::Key << "evaluation" << YAML::Value << b.number;
            out << YAML::Key << "p" << YAML::Value << num(b.p);
            out << YAML::EndMap;
        }
    }
    out << YAML::EndMap;
    dataset::write_file(dir_ / "run.yaml", "# maptune run record (written by the optimizer; read by validate and report)\n" +
                                               std::string(out.c_str()) + "\n");
}

}  // namespace maptune::tuning
