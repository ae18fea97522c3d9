#include "black_box.hpp"

#include <chrono>
#include <fstream>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "command_objective.hpp"
#include "dataset/io.hpp"
#include "experiment/run_files.hpp"
#include "params/parameter_space.hpp"
#include "params/yaml_util.hpp"
#include "run_directory.hpp"

namespace maptune::tuning {

namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace

std::string write_black_box_experiment(const fs::path& run_dir, const BlackBoxSpec& spec) {
    // Checked here so that a bad space names the user's file, not the copy.
    const params::ParameterSpace space = params::ParameterSpace::load(spec.space_file);
    fs::create_directories(run_dir);
    const fs::path space_copy = run_dir / "space.yaml";
    const std::string space_text = read_text(spec.space_file);

    YAML::Emitter out;
    out << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << spec.name;
    out << YAML::Key << "description" << YAML::Value
        << "black-box experiment written by maptune optimize (space copied from " + spec.space_file + ")";
    out << YAML::Key << "space" << YAML::Value << "space.yaml";
    if (!spec.optimize.empty()) out << YAML::Key << "optimize" << YAML::Value << YAML::Flow << spec.optimize;
    out << YAML::Key << "objective" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "command" << YAML::Value << spec.command;
    out << YAML::Key << "direction" << YAML::Value << (spec.minimize ? "minimize" : "maximize");
    out << YAML::Key << "timeout_s" << YAML::Value << params::format_double(spec.timeout_s);
    out << YAML::Key << "parallel" << YAML::Value << spec.parallel;
    out << YAML::EndMap;
    out << YAML::Key << "budget" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "evaluations" << YAML::Value << spec.budget;
    out << YAML::Key << "seconds" << YAML::Value << params::format_double(spec.seconds);
    out << YAML::EndMap;
    out << YAML::Key << "optimizer" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "acquisition" << YAML::Value << spec.acquisition;
    out << YAML::Key << "seed" << YAML::Value << spec.seed;
    out << YAML::Key << "initial_points" << YAML::Value << spec.initial_points;
    out << YAML::Key << "warping" << YAML::Value << spec.warping;
    out << YAML::Key << "search" << YAML::Value << spec.search;
    out << YAML::Key << "quadratic_steps" << YAML::Value << spec.quadratic_steps;
    out << YAML::Key << "hyper_samples" << YAML::Value << spec.hyper_samples;
    out << YAML::Key << "cholesky" << YAML::Value << spec.cholesky;
    out << YAML::EndMap;
    std::vector<std::pair<fs::path, std::string>> starts;
    if (!spec.start_points.empty()) {
        out << YAML::Key << "start_points" << YAML::Value << YAML::BeginSeq;
        for (std::size_t i = 0; i < spec.start_points.size(); ++i) {
            params::load_parameter_set(spec.start_points[i], space);  // names the user's file on error
            const std::string name = "start_point_" + std::to_string(i + 1) + ".yaml";
            starts.emplace_back(run_dir / name, read_text(spec.start_points[i]));
            out << name;
        }
        out << YAML::EndSeq;
    }
    out << YAML::EndMap;
    const std::string text = "# maptune optimize: the black-box experiment of this run directory\n" +
                             std::string(out.c_str()) + "\n";
    const fs::path file = run_dir / "experiment.yaml";
    // Resuming with the same command line is fine; another experiment in the same directory
    // would mix two objectives in one trials.csv.
    if (fs::exists(file) && (read_text(file) != text || (fs::exists(space_copy) && read_text(space_copy) != space_text))) {
        throw params::ConfigError(file.string() + ": this run directory holds another experiment; give another "
                                  "--run-dir, or resume it with --experiment " + file.string());
    }
    dataset::write_file(space_copy, space_text);
    for (const auto& [path, bytes] : starts) dataset::write_file(path, bytes);
    dataset::write_file(file, text);
    // Loading checks everything else (names in `optimize`, ranges) with file and key.
    experiment::load_experiment(file.string());
    return file.string();
}

std::string parameters_json(const experiment::Experiment& e, const params::ParameterSet& set) {
    std::ostringstream out;
    out << "{";
    bool first = true;
    for (const auto& s : e.space.specs()) {
        const auto v = set.find(s.name);
        if (!v) continue;
        out << (first ? "" : ", ") << '"' << s.name << "\": "
            << (s.type == params::ParamType::kInt ? std::to_string(static_cast<long long>(std::llround(*v)))
                                                  : params::format_double(*v));
        first = false;
    }
    out << "}\n";
    return out.str();
}

RunSummary run_black_box(const experiment::Experiment& e, const fs::path& run_dir, std::ostream& log,
                         const std::function<bool()>& stop) {
    if (!e.objective) throw std::invalid_argument(e.file + ": not a black-box experiment (no 'objective')");
    const auto& obj = *e.objective;
    TuningOptions options;
    options.experiment_id = e.name;
    options.incarnation = new_incarnation_id();
    options.resend_s = 1e18;  // a command is never re-sent: its failure is an answer
    TuningRun run(e, options,
                  [](const std::vector<store::PairRecord>&) -> measure::Score {
                      throw std::logic_error("a black-box objective has no per-pair results");
                  },
                  0);
    const RunDirectory files(run_dir, e, {e.name, "", "", "command", "", utc_now()});
    run.resume(experiment::read_trials_csv(files.trials_file(), e.space));
    if (run.resumed() > 0) {
        if (files.space_change()) log << *files.space_change() << "\n";
        log << "resumed " << run.resumed() << " evaluations from " << files.trials_file().string() << "\n";
    }
    files.write_record(run.summary());

    CommandPool pool(obj.command, obj.timeout_s, obj.parallel);
    std::map<std::string, Request> sent;
    const double started = now_s();
    const int budget = e.max_evaluations;
    for (;;) {
        const bool stopping = stop && stop();
        if (const auto reason = run.stop_reason(now_s(), stopping)) {
            pool.kill_all();
            run.finish(*reason);
            break;
        }
        for (const auto& r : run.ask(obj.parallel, now_s())) {
            pool.start(r.id, parameters_json(e, r.params),
                       {{"MAPTUNE_REQUEST_ID", r.id}, {"MAPTUNE_RUN_DIR", fs::absolute(run_dir).string()}});
            sent[r.id] = r;
        }
        if (sent.empty()) {  // nothing asked, nothing running: the time budget ran out mid-way
            run.finish(run.stop_reason(now_s() + 1e-9, false).value_or("the optimizer proposed nothing"));
            break;
        }
        for (const auto& [tag, result] : pool.poll(0.25)) {
            const auto it = sent.find(tag);
            if (it == sent.end()) continue;
            Reply reply;
            reply.request_id = tag;
            reply.ok = result.ok;
            reply.error = result.error;
            reply.params = it->second.params;
            if (result.ok) {
                measure::Score s;
                s.p = result.value;
                reply.score = s;
            }
            const std::string origin = it->second.origin;
            sent.erase(it);
            EvaluationRecord rec;
            if (run.tell(reply, now_s(), &rec) != ReplyOutcome::kAccepted) continue;
            files.write_results(run.summary());
            files.append_hyperparameters(rec.number, run.hyperparameters());
            const auto& s = run.summary();
            log << "evaluation " << rec.number << "/" << budget << " [" << origin << "] ";
            if (rec.failed) {
                log << "failed: " << rec.error;
            } else {
                log << "value " << params::format_double(rec.p);
            }
            if (s.best >= 0) {
                const auto& b = s.evaluations[static_cast<std::size_t>(s.best)];
                log << "  (best " << params::format_double(b.p) << " at " << b.number << ")";
            }
            log << "  " << params::format_fixed(result.wall_s, 2) << " s\n" << std::flush;
        }
    }
    files.write_results(run.summary());
    files.write_record(run.summary(), RunEnd{utc_now(), now_s() - started});
    return run.summary();
}

}  // namespace maptune::tuning
