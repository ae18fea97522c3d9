#pragma once
// Tabular output shared by CLI commands: aligned text table, CSV or JSON array of objects.

#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>

namespace maptune::cli {

enum class TableFormat { kTable, kCsv, kJson, kMarkdown };

struct Table {
    std::vector<std::string> columns;
    std::vector<std::vector<std::string>> rows;  // cells as text
    std::vector<bool> numeric;                   // per column: JSON number, right-aligned
};

void write_table(std::ostream& out, const Table& table, TableFormat format);

}  // namespace maptune::cli
