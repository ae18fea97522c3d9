// Fast DDS shared-memory files in /dev/shm: listing them, and removing the ones a killed
// process left behind without touching those of processes still running (other tests).
#pragma once

#include <sys/stat.h>

#include <cctype>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

namespace maptune::testing {

inline bool is_fastdds_shm_name(const std::string& name) {
    return name.rfind("fastrtps_", 0) == 0 || name.rfind("sem.fastrtps_", 0) == 0;
}

inline std::set<std::string> fastdds_shm_files() {
    std::set<std::string> out;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator("/dev/shm", ec)) {
        const auto name = e.path().filename().string();
        if (is_fastdds_shm_name(name)) out.insert(name);
    }
    return out;
}

// Names of /dev/shm files some live process has mapped (every Fast DDS segment, port and
// named semaphore stays mapped while its owner or a peer uses it).
inline std::set<std::string> mapped_shm_files() {
    std::set<std::string> out;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator("/proc", ec)) {
        const auto pid = e.path().filename().string();
        if (pid.empty() || !std::isdigit(static_cast<unsigned char>(pid[0]))) continue;
        std::ifstream maps(e.path() / "maps");
        for (std::string line; std::getline(maps, line);) {
            const auto at = line.find("/dev/shm/");
            if (at == std::string::npos) continue;
            auto name = line.substr(at + 9);
            if (const auto sp = name.find(' '); sp != std::string::npos) name.resize(sp);
            out.insert(name);
        }
    }
    return out;
}

// Removes Fast DDS files that appeared after `before` and that no live process maps. Files
// younger than 2 s are kept: a concurrently starting participant may not have mapped its
// file yet.
inline std::set<std::string> remove_orphaned_fastdds_shm(const std::set<std::string>& before) {
    const auto mapped = mapped_shm_files();
    std::set<std::string> removed;
    const std::time_t now = std::time(nullptr);
    for (const auto& name : fastdds_shm_files()) {
        if (before.count(name) || mapped.count(name)) continue;
        const std::string path = "/dev/shm/" + name;
        struct stat st {};
        if (stat(path.c_str(), &st) != 0 || now - st.st_ctime < 2) continue;
        std::error_code ec;
        if (std::filesystem::remove(path, ec)) removed.insert(name);
    }
    return removed;
}

}  // namespace maptune::testing
