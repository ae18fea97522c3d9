#pragma once
// DDS domains for tests that run side by side (ctest -j2): a random domain in 1..200 that no
// other test process holds. Two tests on one domain talk to each other's services (a fake
// worker "w1" of one test heartbeating to another test's sample_db) — a rare, real source of
// flaky failures. The lease is an exclusive flock held until this process exits.

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <random>
#include <stdexcept>
#include <string>

namespace maptune::test {

inline int reserve_domain() {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "maptune-test-domains";
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    std::random_device rd;
    std::uniform_int_distribution<int> pick(1, 200);  // below 232: room for 100 participant ids
    for (int attempt = 0; attempt < 1000; ++attempt) {
        const int domain = pick(rd);
        const std::string path = (dir / (std::to_string(domain) + ".lock")).string();
        const int fd = ::open(path.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0666);
        if (fd < 0) continue;
        if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return domain;  // fd stays open: the lease
        ::close(fd);
    }
    throw std::runtime_error("no free DDS test domain in 1..200");
}

}  // namespace maptune::test
