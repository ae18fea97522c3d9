#pragma once
// Child processes for integration tests: started with posix_spawn, output to a file, always
// stopped (SIGTERM, then SIGKILL) when the handle goes away.

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace maptune::testing {

class Process {
public:
    Process() = default;
    Process(const std::vector<std::string>& argv, const std::string& log_file, const std::string& cwd)
        : log_(log_file) {
        posix_spawn_file_actions_t fa;
        posix_spawn_file_actions_init(&fa);
        posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log_file.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
        posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
        posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
        std::vector<char*> args;
        // Run in `cwd` through the shell's cd so relative config paths resolve.
        std::string cmd = "cd '" + cwd + "' && exec";
        for (const auto& a : argv) cmd += " '" + a + "'";
        const char* sh[] = {"/bin/sh", "-c", cmd.c_str(), nullptr};
        if (posix_spawn(&pid_, "/bin/sh", &fa, nullptr, const_cast<char**>(sh), environ) != 0) pid_ = -1;
        posix_spawn_file_actions_destroy(&fa);
    }
    Process(Process&& o) noexcept : pid_(o.pid_), log_(std::move(o.log_)), status_(o.status_) { o.pid_ = -1; }
    Process& operator=(Process&& o) noexcept {
        stop();
        pid_ = o.pid_;
        log_ = std::move(o.log_);
        status_ = o.status_;
        o.pid_ = -1;
        return *this;
    }
    ~Process() { stop(); }

    bool running() {
        if (pid_ <= 0) return false;
        int st = 0;
        if (waitpid(pid_, &st, WNOHANG) == pid_) {
            status_ = st;
            pid_ = -1;
            return false;
        }
        return true;
    }
    void kill_hard() {
        if (pid_ > 0) {
            ::kill(pid_, SIGKILL);
            waitpid(pid_, &status_, 0);
            pid_ = -1;
        }
    }
    // SIGTERM, then SIGKILL after `grace_s`; returns the exit code (-1 if it was killed).
    int stop(double grace_s = 10) {
        if (pid_ > 0) {
            ::kill(pid_, SIGTERM);
            const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(grace_s);
            while (running() && std::chrono::steady_clock::now() < end) {
                std::this_thread::sleep_for(std::chrono::milliseconds(10));
            }
            if (running()) kill_hard();
        }
        return exit_code();
    }
    // Waits for a normal exit; -2 on timeout.
    int wait(double timeout_s) {
        const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
        while (running()) {
            if (std::chrono::steady_clock::now() > end) return -2;
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        return exit_code();
    }
    int exit_code() const { return WIFEXITED(status_) ? WEXITSTATUS(status_) : -1; }
    std::string output() const {
        std::ifstream in(log_);
        std::stringstream s;
        s << in.rdbuf();
        return s.str();
    }

private:
    pid_t pid_ = -1;
    std::string log_;
    int status_ = -1;
};

}  // namespace maptune::testing
