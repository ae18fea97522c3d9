#pragma once
// Polling with a timeout instead of sleeping a fixed time (tests only).

#include <chrono>
#include <thread>

namespace maptune::test {

// Polls `pred` every 5 ms until it is true (returns true) or `timeout` passes (false).
template <class Pred>
bool wait_until(Pred pred, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!pred()) {
        if (std::chrono::steady_clock::now() > deadline) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
}

}  // namespace maptune::test
