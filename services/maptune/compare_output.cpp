#ifdef MAPTUNE_HAVE_EVALUATION
#include "compare_output.hpp"

#include <cmath>

#include "evaluation_cli.hpp"
#include "params/parameter_space.hpp"

namespace maptune::cli {
namespace {

std::string fixed_or_dash(double v, int decimals, bool present) {
    return present ? params::format_fixed(v, decimals) : "-";
}

std::string tau_text(const std::optional<double>& tau) {
    if (!tau) return "";
    return std::isnan(*tau) ? "undefined" : params::format_fixed(*tau, 2);
}

}  // namespace

Table compare_table(const evaluation::CompareResult& r, int baseline_row) {
    Table t;
    t.columns.push_back("set");
    t.numeric.push_back(false);
    for (const auto& col : r.columns) {
        const std::string& l = col.target.label;
        for (const char* c : {" p", " m", " eps", " e_t med [m]", " e_r med [deg]", " s/pair"}) {
            t.columns.push_back(l + c);
            t.numeric.push_back(true);
            if (baseline_row >= 0 && std::string(c) == " p") {
                t.columns.push_back(l + " p - baseline");
                t.numeric.push_back(true);
            }
        }
        if (!col.reference_column.empty()) {
            t.columns.push_back(l + " ref p");
            t.numeric.push_back(true);
        }
    }
    for (std::size_t s = 0; s < r.set_names.size(); ++s) {
        std::vector<std::string> row{r.set_names[s]};
        for (const auto& col : r.columns) {
            const auto& rep = col.cells[s].report;
            const bool matched = rep.score.m > 0;
            row.push_back(params::format_fixed(rep.score.p, 3));
            if (baseline_row >= 0) {
                const double d = rep.score.p - col.cells[static_cast<std::size_t>(baseline_row)].report.score.p;
                row.push_back(static_cast<int>(s) == baseline_row ? "" : (d >= 0 ? "+" : "") + params::format_fixed(d, 3));
            }
            row.push_back(std::to_string(rep.score.m));
            row.push_back(params::format_fixed(rep.score.eps, 3));
            row.push_back(fixed_or_dash(rep.e_t.median, 3, matched));
            row.push_back(fixed_or_dash(rep.e_r.median * 180.0 / M_PI, 2, matched));
            row.push_back(params::format_fixed(rep.mean_pair_s, 3));
            if (!col.reference_column.empty()) {
                const auto& ref = col.cells[s].reference_p;
                row.push_back(ref ? params::format_fixed(*ref, 2) : "");
            }
        }
        t.rows.push_back(std::move(row));
    }
    bool any_tau = false;
    for (const auto& col : r.columns) any_tau |= col.tau.has_value();
    if (any_tau) {
        std::vector<std::string> row{"kendall_tau"};
        for (const auto& col : r.columns) {
            row.push_back(tau_text(col.tau));
            for (int i = 0; i < (baseline_row >= 0 ? 6 : 5); ++i) row.push_back("");
            if (!col.reference_column.empty()) row.push_back("");
        }
        t.rows.push_back(std::move(row));
    }
    return t;
}

nlohmann::json compare_json(const evaluation::CompareResult& r) {
    nlohmann::json views = nlohmann::json::array();
    for (const auto& col : r.columns) {
        nlohmann::json cells = nlohmann::json::array();
        for (std::size_t s = 0; s < r.set_names.size(); ++s) {
            const auto& c = col.cells[s];
            auto j = report_json(c.report, c.wall_seconds, false);
            j["set"] = r.set_names[s];
            j["from_store"] = c.from_store;
            j["reference_p"] = c.reference_p ? nlohmann::json(*c.reference_p) : nlohmann::json();
            cells.push_back(j);
        }
        views.push_back({{"label", col.target.label},
                         {"dataset", col.target.dataset.string()},
                         {"dataset_name", col.dataset_name},
                         {"dataset_id", col.dataset_id},
                         {"world", col.world},
                         {"view", dataset::to_string(col.target.view)},
                         {"reference", dataset::to_string(col.target.reference)},
                         {"pairs", col.pairs},
                         {"m_star", col.settings.m_star},
                         {"m_star_rule", col.m_star_rule},
                         {"e_star", col.settings.e_star},
                         {"reference_column", col.reference_column},
                         {"kendall_tau", col.tau && !std::isnan(*col.tau) ? nlohmann::json(*col.tau) : nlohmann::json()},
                         {"sets", cells}});
    }
    return {{"sets", r.set_names}, {"views", views}};
}

void write_compare_notes(std::ostream& out, const evaluation::CompareResult& r, bool markdown) {
    out << "\n";
    for (const auto& col : r.columns) {
        int evaluated = 0;
        double wall = 0;
        for (const auto& c : col.cells) {
            evaluated += c.from_store ? 0 : 1;
            wall += c.wall_seconds;
        }
        out << (markdown ? "- " : "") << col.target.label << ": " << col.target.dataset.string() << " ("
            << col.dataset_name << ", " << col.dataset_id << "), " << dataset::to_string(col.target.view) << "/"
            << dataset::to_string(col.target.reference) << ", " << col.pairs << " pairs, m* "
            << params::format_fixed(col.settings.m_star, 1) << " (" << col.m_star_rule << "), e* "
            << params::format_double(col.settings.e_star) << "; " << evaluated << " evaluated ("
            << params::format_fixed(wall, 1) << " s), " << col.cells.size() - evaluated << " from the store";
        if (col.tau) {
            out << "; Kendall's tau-b vs reference '" << col.reference_column << "': " << tau_text(col.tau);
        }
        out << "\n";
    }
}

void write_compare(std::ostream& out, const evaluation::CompareResult& r, const std::string& format,
                   int baseline_row) {
    if (format == "json") {
        out << compare_json(r).dump(2) << "\n";
        return;
    }
    const auto f = format == "csv" ? TableFormat::kCsv : format == "table" ? TableFormat::kTable : TableFormat::kMarkdown;
    write_table(out, compare_table(r, baseline_row), f);
    if (f != TableFormat::kCsv) write_compare_notes(out, r, f == TableFormat::kMarkdown);
}

}  // namespace maptune::cli
#endif
