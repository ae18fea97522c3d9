// maptune trials: list the observations in a store.
#include <ctime>
#include <filesystem>
#include <iostream>
#include <set>

#include "commands.hpp"
#include "params/parameter_space.hpp"
#include "store/observation_store.hpp"
#include "table.hpp"

namespace maptune::cli {
namespace {

std::string iso_time(std::int64_t unix_ms) {
    const std::time_t t = static_cast<std::time_t>(unix_ms / 1000);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

}  // namespace

Table observations_table(const std::vector<store::Observation>& observations) {
    std::set<std::string> names;
    for (const auto& o : observations) {
        for (const auto& [name, value] : o.params) names.insert(name);
    }
    Table t;
    t.columns = {"id", "created", "dataset", "view", "matcher", "pairs", "matched", "failed",
                 "timeout", "wall_s"};
    t.numeric = {true, false, false, false, false, true, true, true, true, true};
    for (const auto& n : names) {
        t.columns.push_back(n);
        t.numeric.push_back(true);
    }
    for (const auto& o : observations) {
        std::size_t matched = 0, failed = 0, timeout = 0;
        for (const auto& p : o.pairs) {
            matched += p.matched ? 1 : 0;
            failed += p.status == store::PairStatus::kFailed ? 1 : 0;
            timeout += p.status == store::PairStatus::kTimeout ? 1 : 0;
        }
        std::vector<std::string> row = {std::to_string(o.row_id),
                                         iso_time(o.created_unix_ms),
                                         o.key.dataset_id,
                                         o.key.view,
                                         o.key.matcher_id + "/" + o.key.matcher_version,
                                         std::to_string(o.pairs.size()),
                                         std::to_string(matched),
                                         std::to_string(failed),
                                         std::to_string(timeout),
                                         params::format_fixed(o.wall_seconds, 3)};
        for (const auto& n : names) {
            const auto v = o.params.find(n);
            row.push_back(v ? params::format_double(*v) : "");
        }
        t.rows.push_back(std::move(row));
    }
    return t;
}

void add_trials_command(CLI::App& app, int& exit_code) {
    struct Options {
        std::string db;
        std::string format = "table";
        std::string dataset, view;
        std::size_t limit = 0;
    };
    auto opt = std::make_shared<Options>();
    auto* cmd = app.add_subcommand("trials", "List the observations stored in an observation database.");
    cmd->add_option("--db", opt->db, "observation store (SQLite file); must exist")->required();
    cmd->add_option("-f,--format", opt->format, "output format: table | csv | json (default: table)")
        ->check(CLI::IsMember({"table", "csv", "json"}));
    cmd->add_option("--dataset", opt->dataset, "only this dataset id (default: all)");
    cmd->add_option("--view", opt->view, "only this view, e.g. complete | subsequent (default: all)");
    cmd->add_option("--limit", opt->limit, "at most this many rows, 0 = all (default: 0)");
    cmd->callback([opt, &exit_code] {
        if (!std::filesystem::exists(opt->db)) {
            std::cerr << "maptune trials: " << opt->db << ": no such file\n";
            exit_code = 2;
            return;
        }
        try {
            const store::ObservationStore db(opt->db);
            store::ObservationFilter filter;
            if (!opt->dataset.empty()) filter.dataset_id = opt->dataset;
            if (!opt->view.empty()) filter.view = opt->view;
            filter.limit = opt->limit;
            const TableFormat format = opt->format == "csv"    ? TableFormat::kCsv
                                       : opt->format == "json" ? TableFormat::kJson
                                                               : TableFormat::kTable;
            write_table(std::cout, observations_table(db.list(filter)), format);
        } catch (const store::StoreError& e) {
            std::cerr << "maptune trials: " << e.what() << "\n";
            exit_code = 2;
        }
    });
}

}  // namespace maptune::cli
