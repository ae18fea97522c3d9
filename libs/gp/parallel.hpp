#pragma once
// A bounded parallel loop for the few hot loops of gp and bo (batched prediction, the starts
// of a fit, the acquisition polish). Each task writes only its own results, so neither the
// thread count nor which thread ran a task changes a result.

#include <functional>

namespace maptune::gp {

// Upper bound for threads = 0 ("as many as the hardware has"): a burst inside one ask should
// not take over a large machine shared with the evaluation workers.
constexpr int kMaxAutoThreads = 4;

// Threads for a `threads` option: 0 = std::thread::hardware_concurrency() capped at
// kMaxAutoThreads; otherwise the value itself, at least 1.
int resolve_threads(int threads);

// Runs task(i) for every i in [0, count) on min(threads, count) threads, the calling thread
// included; each thread takes the next task in order when it is free. After all have finished,
// rethrows the exception of the lowest-numbered task that threw.
void parallel_for(int count, int threads, const std::function<void(int)>& task);

}  // namespace maptune::gp
