#include "dds/domain_lease.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

namespace maptune::dds {
namespace {

std::mutex g_mutex;
std::set<int> g_held;  // leases of this process (a second flock of our own would conflict)

// Caller holds g_mutex. The descriptor of a taken lease stays open until exit.
bool try_lease(int domain) {
    if (g_held.count(domain)) return true;
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path dir = fs::temp_directory_path(ec) / "maptune-dds-domains";
    fs::create_directories(dir, ec);
    const std::string path = (dir / (std::to_string(domain) + ".lock")).string();
    const int fd = ::open(path.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0666);
    if (fd < 0) return false;
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
        ::close(fd);
        return false;
    }
    g_held.insert(domain);
    return true;
}

}  // namespace

int lease_random_domain(int lo, int hi) {
    std::lock_guard<std::mutex> lock(g_mutex);
    std::random_device rd;
    std::uniform_int_distribution<int> pick(lo, hi);
    for (int attempt = 0; attempt < 1000; ++attempt) {
        const int domain = pick(rd);
        if (!g_held.count(domain) && try_lease(domain)) return domain;
    }
    throw std::runtime_error("no free DDS domain in " + std::to_string(lo) + ".." + std::to_string(hi) +
                             ": other maptune processes hold them all");
}

bool lease_domain(int domain) {
    std::lock_guard<std::mutex> lock(g_mutex);
    return try_lease(domain);
}

}  // namespace maptune::dds
