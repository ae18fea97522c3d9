// maptune score: the performance measure p of a list of matched pairs' errors (JSON).
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "commands.hpp"
#include "measure/measure.hpp"

namespace maptune::cli {
namespace {

// Reads a finite number at `key` of `obj`; `where` names the object in messages.
double number_at(const nlohmann::json& obj, const std::string& key, const std::string& where) {
    const auto& v = obj.at(key);
    // The type, not the value: dumping a hostile, deeply nested value recursed off the stack.
    if (!v.is_number()) throw std::invalid_argument(where + key + ": expected a number, got " + v.type_name());
    return v.get<double>();
}

measure::Score score_document(const nlohmann::json& doc, measure::MeasureSettings& settings) {
    if (!doc.is_object()) throw std::invalid_argument("expected a JSON object at the top level");
    for (const auto& [key, value] : doc.items()) {
        if (key != "e_star" && key != "m_star" && key != "w_v" && key != "matches") {
            throw std::invalid_argument("unknown key '" + key +
                                        "' (expected e_star, m_star, w_v, matches)");
        }
    }
    if (doc.contains("e_star")) settings.e_star = number_at(doc, "e_star", "");
    if (doc.contains("m_star")) settings.m_star = number_at(doc, "m_star", "");
    if (doc.contains("w_v")) settings.w_v = number_at(doc, "w_v", "");
    if (auto bad = measure::check_settings(settings); !bad.empty()) throw std::invalid_argument(bad);
    if (!doc.contains("matches") || !doc["matches"].is_array()) {
        throw std::invalid_argument("'matches' must be an array of {e_t, e_r, d} objects");
    }
    std::vector<measure::MatchError> errors;
    const auto& matches = doc["matches"];
    for (std::size_t i = 0; i < matches.size(); ++i) {
        const std::string where = "matches[" + std::to_string(i) + "].";
        const auto& m = matches[i];
        if (!m.is_object()) throw std::invalid_argument(where + ": expected an object");
        for (const char* key : {"e_t", "e_r", "d"}) {
            if (!m.contains(key)) throw std::invalid_argument(where + key + ": missing");
        }
        for (const auto& [key, value] : m.items()) {
            if (key != "e_t" && key != "e_r" && key != "d") {
                throw std::invalid_argument(where + key + ": unknown key (expected e_t, e_r, d)");
            }
        }
        errors.push_back({number_at(m, "e_t", where), number_at(m, "e_r", where),
                          number_at(m, "d", where)});
    }
    if (auto bad = measure::check_errors(errors); !bad.empty()) throw std::invalid_argument(bad);
    return measure::score(errors, settings);
}

}  // namespace

void add_score_command(CLI::App& app, int& exit_code) {
    auto* cmd = app.add_subcommand(
        "score",
        "Compute the performance measure p (SPEC §2) of matched pairs' errors.\n"
        "Input JSON: {\"e_star\": 0.4, \"m_star\": 60, \"w_v\": 0.5, \"matches\": "
        "[{\"e_t\": 0.1, \"e_r\": 0.02, \"d\": 5.0}, ...]}\n"
        "e_t [m] translation error, e_r [rad] rotation error, d [m] submap size.\n"
        "e_star: > 0.05 m, default 0.4; m_star: > 0, default 60; w_v: [0, 1], default 0.5.\n"
        "Prints one JSON object: p, v, eps, m, mean_rating and the settings. Exit 2 on bad input.");
    auto file = std::make_shared<std::string>("-");
    cmd->add_option("input", *file, "JSON file, or - for standard input (default: -)");
    cmd->callback([file, &exit_code] {
        std::string source = *file == "-" ? "<stdin>" : *file;
        std::stringstream text;
        if (*file == "-") {
            text << std::cin.rdbuf();
        } else {
            std::ifstream in(*file);
            if (!in) {
                std::cerr << "maptune score: " << source << ": cannot open file\n";
                exit_code = 2;
                return;
            }
            text << in.rdbuf();
        }
        try {
            const auto doc = nlohmann::json::parse(text.str());
            measure::MeasureSettings settings;
            const measure::Score s = score_document(doc, settings);
            nlohmann::json out = {{"p", s.p},
                                  {"v", s.v},
                                  {"eps", s.eps},
                                  {"m", s.m},
                                  {"mean_rating", s.mean_rating},
                                  {"e_star", settings.e_star},
                                  {"m_star", settings.m_star},
                                  {"w_v", settings.w_v}};
            std::cout << out.dump() << "\n";
        } catch (const nlohmann::json::parse_error& e) {
            std::cerr << "maptune score: " << source << ": invalid JSON: " << e.what() << "\n";
            exit_code = 2;
        } catch (const std::exception& e) {
            std::cerr << "maptune score: " << source << ": " << e.what() << "\n";
            exit_code = 2;
        }
    });
}

}  // namespace maptune::cli
