#pragma once
// Black-box objectives run as shell commands (`maptune optimize`, issue 15): one child process
// per parameter set, the set as JSON on its standard input, one number — or a JSON object with
// `value` and optional `failed`/`reason` — on its standard output. A non-zero exit, a timeout,
// a signal or unreadable output is a failed evaluation with a reason, never the end of a run.
// The one part of libs/tuning that touches the operating system (processes, pipes, clocks).

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace maptune::tuning {

struct ObjectiveResult {
    bool ok = false;
    double value = 0;     // when ok
    std::string error;    // why not ok: exit status, timeout, output that is not a number, ...
    double wall_s = 0;
};

// Reads an objective's standard output: its last non-empty line is a finite number or a JSON
// object {"value": number, "failed": bool, "reason": text}. `failed: true` (value optional)
// is a failure with that reason.
ObjectiveResult parse_objective_output(const std::string& stdout_text);

// Runs up to `parallel` commands at once through /bin/sh -c, each in its own process group so
// that a timeout stops everything the command started.
class CommandPool {
public:
    CommandPool(std::string command, double timeout_s, int parallel);
    ~CommandPool();  // kills what still runs
    CommandPool(const CommandPool&) = delete;
    CommandPool& operator=(const CommandPool&) = delete;

    int free_slots() const { return parallel_ - static_cast<int>(children_.size()); }
    int running() const { return static_cast<int>(children_.size()); }

    // Starts the command for `tag` with `input` on its standard input and `env` added to the
    // environment. A command that cannot be started finishes at once as a failure.
    void start(const std::string& tag, const std::string& input, const std::map<std::string, std::string>& env);
    // Waits at most `wait_s` for output or exits; returns the commands that finished.
    std::vector<std::pair<std::string, ObjectiveResult>> poll(double wait_s);
    // Stops every running command (SIGTERM to its group, SIGKILL after a short grace).
    void kill_all();

private:
    struct Child {
        std::string tag;
        int pid = -1;
        int in = -1, out = -1, err = -1;
        std::string input;
        std::size_t written = 0;
        std::string stdout_text, stderr_text;
        double started = 0;
        bool timed_out = false;
    };
    void finish(Child& c, int status, std::vector<std::pair<std::string, ObjectiveResult>>& done);
    // Calls on_exit(child, wait status) for each child that exited and drops it.
    void reap(const std::function<void(Child&, int)>& on_exit);

    std::string command_;
    double timeout_s_;
    int parallel_;
    std::vector<Child> children_;
    std::vector<std::pair<std::string, ObjectiveResult>> pending_;  // failed to start
};

}  // namespace maptune::tuning
