// maptune_dataset_server: serves dataset directories to workers and optimizers over DDS.
#include <CLI/CLI.hpp>
#include <iostream>
#include <thread>

#include "dataset_server.hpp"
#include "dds_options.hpp"
#include "runtime.hpp"

int main(int argc, char** argv) {
    using namespace maptune::services;
    CLI::App app{"maptune dataset_server: announces datasets and serves their files over DDS"};
    maptune::dds::ParticipantOptions dds{0, "", "maptune_loopback", "dataset_server"};
    DatasetServerOptions options;
    std::vector<std::string> dirs;
    app.add_option("--dataset", dirs, "dataset directory (repeatable)")->required()->check(CLI::ExistingDirectory);
    app.add_option("--chunk-bytes", options.chunk_bytes, "file chunk size in bytes (default: 524288)");
    add_dds_options(app, dds, "dataset_server");
    CLI11_PARSE(app, argc, argv);
    install_stop_signals();
    for (const auto& d : dirs) options.datasets.emplace_back(d);
    try {
        maptune::dds::Participant participant(dds);
        DatasetServer server(participant, options);
        for (const auto& id : server.dataset_ids()) std::cout << "serving dataset " << id << std::endl;
        std::cout << "ready on domain " << dds.domain_id << std::endl;
        while (!stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
        std::cout << "stopping: served " << server.requests_served() << " files" << std::endl;
    } catch (const std::exception& e) {
        std::cerr << "dataset_server: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
