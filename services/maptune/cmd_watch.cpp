// maptune watch: prints best-so-far updates as the optimizer publishes them.
#ifdef MAPTUNE_HAVE_SERVICES
#include <iostream>
#include <mutex>
#include <thread>

#include "commands.hpp"
#include "dds/convert.hpp"
#include "dds/validate.hpp"
#include "refusals.hpp"
#include "dds_options.hpp"
#include "maptunePubSubTypes.h"
#include "params/parameter_space.hpp"
#include "runtime.hpp"

namespace maptune::cli {
namespace {

std::string format_params(const std::vector<msg::v1::NamedValue>& values) {
    std::string s;
    for (const auto& nv : values) s += " " + nv.name() + "=" + params::format_double(nv.value());
    return s;
}

}  // namespace

void add_watch_command(CLI::App& app, int& exit_code) {
    struct Options {
        dds::ParticipantOptions dds{0, "", "maptune_loopback", "watch"};
        std::string experiment;
        bool once = false;
        double timeout_s = 0;
    };
    auto opt = std::make_shared<Options>();
    auto* cmd = app.add_subcommand("watch",
                                   "Print best-so-far parameters live as the optimizer publishes them "
                                   "(a late start prints the current best at once).");
    services::add_dds_options(*cmd, opt->dds, "watch");
    cmd->add_option("--experiment", opt->experiment, "only this experiment id (default: all)");
    cmd->add_flag("--once", opt->once, "exit after the first update");
    cmd->add_option("--timeout", opt->timeout_s, "exit after this many seconds, 0 = never (default: 0)");
    cmd->callback([opt, &exit_code] {
        services::install_stop_signals();
        namespace v1 = msg::v1;
        try {
            dds::Participant participant(opt->dds);
            std::mutex m;
            int updates = 0;
            services::RefusalLog refusals("maptune watch");
            // Declared after what the callbacks touch: closed before it goes.
            const auto best_sub = participant.reader<v1::BestSoFarPubSubType>(
                dds::topics::kBestSoFar, dds::TopicQos::kLatched, [&](const v1::BestSoFar& b) {
                    if (!opt->experiment.empty() && b.experiment_id() != opt->experiment) return;
                    if (auto bad = dds::check(b); !bad.empty()) return refusals.refused("best_so_far", "", bad);
                    std::lock_guard<std::mutex> lock(m);
                    std::cout << b.experiment_id() << ": " << b.evaluations() << " evaluations, best p="
                              << params::format_fixed(b.best_p(), 4) << " (evaluation "
                              << b.best_evaluation() << ")" << format_params(b.best_params());
                    if (!b.predicted_params().empty()) {
                        std::cout << " | GP predicted best " << params::format_fixed(b.predicted_mean(), 4)
                                  << " ± " << params::format_fixed(b.predicted_std(), 4)
                                  << format_params(b.predicted_params());
                    }
                    std::cout << std::endl;
                    ++updates;
                });
            const auto status_sub = participant.reader<v1::OptimizerStatusPubSubType>(
                dds::topics::kOptimizerStatus, dds::TopicQos::kLatched, [&](const v1::OptimizerStatus& s) {
                    if (!opt->experiment.empty() && s.experiment_id() != opt->experiment) return;
                    if (s.state() == "running") return;
                    if (auto bad = dds::check(s); !bad.empty()) return refusals.refused("optimizer_status", "", bad);
                    std::lock_guard<std::mutex> lock(m);
                    std::cout << s.experiment_id() << ": " << s.state() << " after " << s.evaluations()
                              << " evaluations (" << s.message() << ")" << std::endl;
                });
            const double end = opt->timeout_s > 0 ? services::now_s() + opt->timeout_s : 1e300;
            while (!services::stop_requested() && services::now_s() < end) {
                {
                    std::lock_guard<std::mutex> lock(m);
                    if (opt->once && updates > 0) break;
                }
                std::this_thread::sleep_for(std::chrono::milliseconds(20));
            }
            exit_code = opt->once && updates == 0 ? 1 : 0;
        } catch (const std::exception& e) {
            std::cerr << "maptune watch: " << e.what() << "\n";
            exit_code = 1;
        }
    });
}

}  // namespace maptune::cli
#endif
