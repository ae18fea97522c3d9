#pragma once
// Process plumbing shared by the services: stop on SIGINT/SIGTERM, a monotonic clock, and a
// small logger line format.

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

namespace maptune::services {

// Installs SIGINT/SIGTERM handlers that set the global stop flag (once per process).
void install_stop_signals();
// Caps glibc's malloc arenas at the core count (at least 2) unless MALLOC_ARENA_MAX is set.
// glibc's default of 8 per core let freed feature-cache memory stay scattered over 16 arenas:
// a full-moon run reached 22.3 GB resident for a 10 GB cache, 15.8 GB with 2 arenas
// (BENCHMARKS.md, "Full moon scale"). Call first thing in main, before any thread starts.
void bound_malloc_arenas();
// True once a stop signal arrived or request_stop() was called.
bool stop_requested();
void request_stop();

// Seconds on a monotonic clock (for leases and timeouts).
double now_s();

// Wall-clock time in UTC, by strftime format (default ISO 8601: "2026-12-02T10:31:30Z").
std::string utc_now(const char* format = "%Y-%m-%dT%H:%M:%SZ");

// A random id for one life of a service (hex, 12 digits): part of every id it hands out
// (request and task ids), so that answers addressed to an earlier life — before a restart,
// or to another process of the same name — are recognized as stale, never as current.
std::string incarnation_id();

// A unique id for this process/thread role, e.g. "worker-host-1234-1".
std::string make_id(const std::string& role);

// Sleeps in small steps until `pred` is true, the stop flag is set, or `timeout_s` passes.
template <class Pred>
bool wait_for(Pred pred, double timeout_s) {
    const double end = now_s() + timeout_s;
    while (!pred()) {
        if (stop_requested() || now_s() > end) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
}

}  // namespace maptune::services
