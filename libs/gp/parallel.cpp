#include "gp/parallel.hpp"

#include <algorithm>
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
    auto run = [&](int thread) {
        for (int i = thread; i < count; i += used) {
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
        // No more threads to be had: the calling thread runs the remaining shares itself.
    }
    run(0);
    for (int t = started; t < used; ++t) run(t);
    for (std::thread& w : workers) w.join();
    for (const std::exception_ptr& e : errors) {
        if (e) std::rethrow_exception(e);
    }
}

}  // namespace maptune::gp
