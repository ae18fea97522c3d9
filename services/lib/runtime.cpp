#include "runtime.hpp"

#include "tuning/run_directory.hpp"

#include <unistd.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <ctime>
#include <mutex>
#include <random>

namespace maptune::services {
namespace {

std::atomic<bool> g_stop{false};

extern "C" void on_stop_signal(int) { g_stop.store(true); }

}  // namespace

void bound_malloc_arenas() {
#ifdef __GLIBC__
    if (std::getenv("MALLOC_ARENA_MAX") != nullptr) return;  // the user's choice stands
    const unsigned cores = std::thread::hardware_concurrency();
    mallopt(M_ARENA_MAX, static_cast<int>(std::max(2u, cores)));
#endif
}

void install_stop_signals() {
    static std::once_flag once;
    std::call_once(once, [] {
        struct sigaction sa {};
        sa.sa_handler = on_stop_signal;
        sigemptyset(&sa.sa_mask);
        sigaction(SIGINT, &sa, nullptr);
        sigaction(SIGTERM, &sa, nullptr);
    });
}

std::string utc_now(const char* format) { return tuning::utc_now(format); }

bool stop_requested() { return g_stop.load(); }
void request_stop() { g_stop.store(true); }

double now_s() { return tuning::now_s(); }

std::string incarnation_id() { return tuning::new_incarnation_id(); }

std::string make_id(const std::string& role) {
    static std::atomic<int> counter{0};
    char host[64] = {};
    gethostname(host, sizeof(host) - 1);
    return role + "-" + host + "-" + std::to_string(getpid()) + "-" + std::to_string(++counter);
}

}  // namespace maptune::services
