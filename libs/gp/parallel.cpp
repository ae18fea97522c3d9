#include "gp/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <system_error>
#include <thread>
#include <vector>

namespace maptune::gp {

int resolve_threads(int threads) {
    if (threads > 0) return threads;
    const auto hardware = static_cast<int>(std::thread::hardware_concurrency());
    return std::clamp(hardware, 1, kMaxAutoThreads);
}

void parallel_for(int count, int threads, const std::function<void(int)>& task) {
    const int used = std::clamp(threads, 1, std::max(count, 1));
    std::vector<std::exception_ptr> errors(static_cast<std::size_t>(std::max(count, 0)));
    // Dynamic: a thread takes the next task when it is done, so tasks of unequal length (the
    // starts of a fit) keep every thread busy.
    std::atomic<int> next{0};
    auto run = [&](int) {
        for (int i = next++; i < count; i = next++) {
            try {
                task(i);
            } catch (...) {
                errors[static_cast<std::size_t>(i)] = std::current_exception();
            }
        }
    };
    std::vector<std::thread> workers;
    workers.reserve(static_cast<std::size_t>(used - 1));
    int started = 1;
    try {
        for (; started < used; ++started) workers.emplace_back(run, started);
    } catch (const std::system_error&) {
        // No more threads to be had: the calling thread runs what the others do not take.
    }
    run(0);
    for (std::thread& w : workers) w.join();
    for (const std::exception_ptr& e : errors) {
        if (e) std::rethrow_exception(e);
    }
}

}  // namespace maptune::gp
