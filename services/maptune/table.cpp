#include "table.hpp"

#include <algorithm>
#include <cstdlib>

namespace maptune::cli {
namespace {

std::string csv_cell(const std::string& s) {
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string q = "\"";
    for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
}

}  // namespace

void write_table(std::ostream& out, const Table& t, TableFormat format) {
    const std::size_t n = t.columns.size();
    auto is_numeric = [&](std::size_t c) { return c < t.numeric.size() && t.numeric[c]; };
    if (format == TableFormat::kJson) {
        nlohmann::json rows = nlohmann::json::array();
        for (const auto& row : t.rows) {
            nlohmann::json obj = nlohmann::json::object();
            for (std::size_t c = 0; c < n && c < row.size(); ++c) {
                if (is_numeric(c) && !row[c].empty()) {
                    obj[t.columns[c]] = std::strtod(row[c].c_str(), nullptr);
                } else {
                    obj[t.columns[c]] = row[c];
                }
            }
            rows.push_back(obj);
        }
        out << rows.dump(2) << "\n";
        return;
    }
    if (format == TableFormat::kCsv) {
        for (std::size_t c = 0; c < n; ++c) out << (c ? "," : "") << csv_cell(t.columns[c]);
        out << "\n";
        for (const auto& row : t.rows) {
            for (std::size_t c = 0; c < n; ++c) out << (c ? "," : "") << csv_cell(c < row.size() ? row[c] : "");
            out << "\n";
        }
        return;
    }
    std::vector<std::size_t> width(n);
    for (std::size_t c = 0; c < n; ++c) width[c] = t.columns[c].size();
    for (const auto& row : t.rows) {
        for (std::size_t c = 0; c < n && c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
    }
    const bool md = format == TableFormat::kMarkdown;
    auto line = [&](const std::vector<std::string>& cells) {
        for (std::size_t c = 0; c < n; ++c) {
            std::string cell = c < cells.size() ? cells[c] : "";
            if (md) {  // a '|' inside a cell would split it
                for (auto pos = cell.find('|'); pos != std::string::npos; pos = cell.find('|', pos + 2)) {
                    cell.replace(pos, 1, "\\|");
                }
            }
            const std::string pad(width[c] > cell.size() ? width[c] - cell.size() : 0, ' ');
            if (md) {
                out << (c ? " | " : "| ") << (is_numeric(c) ? pad + cell : cell + pad);
            } else {
                out << (c ? "  " : "") << (is_numeric(c) ? pad + cell : cell + (c + 1 < n ? pad : ""));
            }
        }
        out << (md ? " |\n" : "\n");
    };
    line(t.columns);
    if (md) {
        for (std::size_t c = 0; c < n; ++c) {
            const std::size_t w = std::max<std::size_t>(width[c], 3);
            out << (c ? " | " : "| ") << (is_numeric(c) ? std::string(w - 1, '-') + ":" : std::string(w, '-'));
        }
        out << " |\n";
    }
    for (const auto& row : t.rows) line(row);
}

}  // namespace maptune::cli
