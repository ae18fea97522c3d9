// bo_bench: the `maptune bo-bench` subcommand as its own executable.
#include <string>
#include <vector>

#include "commands.hpp"

int main(int argc, char** argv) {
    CLI::App app{"bo_bench — optimizer regret and timing benchmarks (same as maptune bo-bench)"};
    int exit_code = 0;
    maptune::cli::add_bo_bench_command(app, exit_code);
    // Run the subcommand without having to name it.
    std::vector<std::string> args{"bo-bench"};
    for (int i = 1; i < argc; ++i) args.emplace_back(argv[i]);
    std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 wants them reversed
    try {
        app.parse(reversed);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;
    }
    return exit_code;
}
