#include "command_objective.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "run_directory.hpp"

extern char** environ;

namespace maptune::tuning {
namespace {

std::string trim(const std::string& s) {
    const auto b = s.find_first_not_of(" \t\r\n");
    if (b == std::string::npos) return {};
    return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}

// The last lines of a text, for an error message (a failing command's stderr).
std::string tail(const std::string& s, std::size_t max_chars = 300) {
    std::string t = trim(s);
    if (t.size() > max_chars) t = "..." + t.substr(t.size() - max_chars);
    for (char& c : t) c = (c == '\n' || c == '\r') ? ' ' : c;
    return t;
}

void close_fd(int& fd) {
    if (fd >= 0) ::close(fd);
    fd = -1;
}

// Reads what is available; false at end of file or on an error.
bool drain(int fd, std::string& into, std::size_t cap) {
    char buf[4096];
    for (;;) {
        const ssize_t n = ::read(fd, buf, sizeof buf);
        if (n > 0) {
            // Keep the end: the value is the last line, an error the last words.
            into.append(buf, static_cast<std::size_t>(n));
            if (into.size() > cap) into.erase(0, into.size() - cap);
            continue;
        }
        if (n == 0) return false;
        if (errno == EINTR) continue;
        return errno == EAGAIN || errno == EWOULDBLOCK;
    }
}

constexpr std::size_t kStdoutCap = 1 << 20;
constexpr std::size_t kStderrCap = 1 << 14;
constexpr double kKillGrace = 2.0;  // seconds between SIGTERM and SIGKILL

}  // namespace

ObjectiveResult parse_objective_output(const std::string& text) {
    ObjectiveResult r;
    std::string line;
    std::size_t end = text.size();
    while (line.empty() && end > 0) {
        const auto nl = text.rfind('\n', end - 1);
        const std::size_t begin = nl == std::string::npos ? 0 : nl + 1;
        line = trim(text.substr(begin, end - begin));
        end = nl == std::string::npos ? 0 : nl;
    }
    if (line.empty()) {
        r.error = "the objective printed nothing (expected a number or {\"value\": ...} on its last line)";
        return r;
    }
    char* stop = nullptr;
    errno = 0;
    const double v = std::strtod(line.c_str(), &stop);
    if (stop != line.c_str() && *stop == '\0' && errno == 0) {
        if (!std::isfinite(v)) {
            r.error = "the objective's value is not finite: '" + line + "'";
            return r;
        }
        r.ok = true;
        r.value = v;
        return r;
    }
    const auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object()) {
        r.error = "the last line of the objective's output is neither a number nor a JSON object: '" + tail(line, 200) + "'";
        return r;
    }
    const auto reason = j.find("reason");
    const std::string why = reason != j.end() && reason->is_string() ? reason->get<std::string>() : std::string();
    const auto failed = j.find("failed");
    if (failed != j.end()) {
        if (!failed->is_boolean()) {
            r.error = "the objective's 'failed' is not true or false: '" + tail(line, 200) + "'";
            return r;
        }
        if (failed->get<bool>()) {
            r.error = why.empty() ? "the objective reported a failure" : "the objective reported a failure: " + why;
            return r;
        }
    }
    const auto value = j.find("value");
    if (value == j.end() || !value->is_number() || !std::isfinite(value->get<double>())) {
        r.error = "the objective's JSON has no finite number 'value': '" + tail(line, 200) + "'";
        return r;
    }
    r.ok = true;
    r.value = value->get<double>();
    return r;
}

CommandPool::CommandPool(std::string command, double timeout_s, int parallel)
    : command_(std::move(command)), timeout_s_(timeout_s), parallel_(std::max(1, parallel)) {
    if (trim(command_).empty()) throw std::invalid_argument("the objective command is empty");
    // A command that exits without reading its input must not kill us by SIGPIPE; children get
    // the default disposition back (POSIX_SPAWN_SETSIGDEF below).
    ::signal(SIGPIPE, SIG_IGN);
}

CommandPool::~CommandPool() { kill_all(); }

void CommandPool::start(const std::string& tag, const std::string& input, const std::map<std::string, std::string>& env) {
    Child c;
    c.tag = tag;
    c.input = input;
    c.started = now_s();
    int in[2] = {-1, -1}, out[2] = {-1, -1}, err[2] = {-1, -1};
    auto fail = [&](const std::string& why) {
        for (int* p : {in, out, err}) {
            close_fd(p[0]);
            close_fd(p[1]);
        }
        ObjectiveResult r;
        r.error = "cannot start the objective command: " + why;
        pending_.emplace_back(tag, r);
    };
    if (::pipe2(in, O_CLOEXEC) != 0 || ::pipe2(out, O_CLOEXEC) != 0 || ::pipe2(err, O_CLOEXEC) != 0) {
        return fail(std::strerror(errno));
    }
    std::vector<std::string> env_strings;
    for (char** e = environ; *e; ++e) {
        const std::string kv(*e);
        if (!env.count(kv.substr(0, kv.find('=')))) env_strings.push_back(kv);
    }
    for (const auto& [k, v] : env) env_strings.push_back(k + "=" + v);
    std::vector<char*> envp;
    for (auto& s : env_strings) envp.push_back(s.data());
    envp.push_back(nullptr);
    std::string sh = "/bin/sh", dash_c = "-c";
    std::string cmd = command_;
    char* argv[] = {sh.data(), dash_c.data(), cmd.data(), nullptr};

    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, in[0], STDIN_FILENO);
    posix_spawn_file_actions_adddup2(&fa, out[1], STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&fa, err[1], STDERR_FILENO);
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    sigset_t defaults;
    sigemptyset(&defaults);
    for (int s : {SIGPIPE, SIGINT, SIGTERM}) sigaddset(&defaults, s);
    sigset_t none;
    sigemptyset(&none);
    posix_spawnattr_setsigdefault(&attr, &defaults);
    posix_spawnattr_setsigmask(&attr, &none);
    posix_spawnattr_setpgroup(&attr, 0);  // its own group: a timeout stops what it started
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);
    pid_t pid = -1;
    const int rc = ::posix_spawn(&pid, sh.c_str(), &fa, &attr, argv, envp.data());
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&attr);
    if (rc != 0) return fail(std::strerror(rc));
    close_fd(in[0]);
    close_fd(out[1]);
    close_fd(err[1]);
    c.pid = pid;
    c.in = in[1];
    c.out = out[0];
    c.err = err[0];
    for (int fd : {c.in, c.out, c.err}) ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
    if (c.input.empty()) close_fd(c.in);
    children_.push_back(std::move(c));
}

void CommandPool::finish(Child& c, int status, std::vector<std::pair<std::string, ObjectiveResult>>& done) {
    if (c.out >= 0) drain(c.out, c.stdout_text, kStdoutCap);
    if (c.err >= 0) drain(c.err, c.stderr_text, kStderrCap);
    close_fd(c.in);
    close_fd(c.out);
    close_fd(c.err);
    ObjectiveResult r;
    const std::string err = tail(c.stderr_text);
    const std::string said = err.empty() ? "" : ": " + err;
    if (c.timed_out) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%g", timeout_s_);
        r.error = std::string("timeout: the objective ran longer than ") + buf + " s" + said;
    } else if (WIFSIGNALED(status)) {
        r.error = "the objective was killed by signal " + std::to_string(WTERMSIG(status)) + said;
    } else if (WIFEXITED(status) && WEXITSTATUS(status) != 0) {
        r.error = "the objective exited with status " + std::to_string(WEXITSTATUS(status)) + said;
    } else {
        r = parse_objective_output(c.stdout_text);
    }
    r.wall_s = now_s() - c.started;
    done.emplace_back(c.tag, r);
}

std::vector<std::pair<std::string, ObjectiveResult>> CommandPool::poll(double wait_s) {
    std::vector<std::pair<std::string, ObjectiveResult>> done;
    done.swap(pending_);
    const double deadline = now_s() + std::max(0.0, wait_s);
    while (!children_.empty()) {
        // Time-outs first: SIGTERM to the group, SIGKILL after the grace.
        const double t = now_s();
        double next_event = deadline;
        for (auto& c : children_) {
            if (timeout_s_ <= 0) continue;
            const double elapsed = t - c.started;
            if (!c.timed_out && elapsed > timeout_s_) {
                c.timed_out = true;
                ::kill(-c.pid, SIGTERM);
            }
            if (c.timed_out && elapsed > timeout_s_ + kKillGrace) ::kill(-c.pid, SIGKILL);
            next_event = std::min(next_event, c.started + timeout_s_ + (c.timed_out ? kKillGrace : 0) + 0.01);
        }
        // Exits.
        reap([&](Child& c, int status) { finish(c, status, done); });
        if (!done.empty() || children_.empty()) break;
        const double now = now_s();
        if (now >= deadline) break;
        // Wait for output, room for input, or the next deadline; exits show up as end of file
        // on stdout/stderr, and a child that closed both is polled every 50 ms.
        std::vector<pollfd> fds;
        std::vector<std::pair<std::size_t, int>> owner;  // child, which fd (0 in, 1 out, 2 err)
        for (std::size_t i = 0; i < children_.size(); ++i) {
            const auto& c = children_[i];
            if (c.in >= 0) fds.push_back({c.in, POLLOUT, 0}), owner.emplace_back(i, 0);
            if (c.out >= 0) fds.push_back({c.out, POLLIN, 0}), owner.emplace_back(i, 1);
            if (c.err >= 0) fds.push_back({c.err, POLLIN, 0}), owner.emplace_back(i, 2);
        }
        double wait = std::min(next_event, deadline) - now;
        if (fds.size() < children_.size() * 2) wait = std::min(wait, 0.05);
        const int ms = static_cast<int>(std::ceil(std::max(0.0, wait) * 1000));
        const int n = ::poll(fds.data(), fds.size(), ms);
        if (n < 0 && errno != EINTR) break;
        for (std::size_t k = 0; n > 0 && k < fds.size(); ++k) {
            if (fds[k].revents == 0) continue;
            auto& c = children_[owner[k].first];
            switch (owner[k].second) {
                case 0: {
                    const ssize_t w = ::write(c.in, c.input.data() + c.written, c.input.size() - c.written);
                    if (w > 0) c.written += static_cast<std::size_t>(w);
                    if ((w < 0 && errno != EAGAIN && errno != EINTR) || c.written >= c.input.size()) close_fd(c.in);
                    break;
                }
                case 1:
                    if (!drain(c.out, c.stdout_text, kStdoutCap)) close_fd(c.out);
                    break;
                default:
                    if (!drain(c.err, c.stderr_text, kStderrCap)) close_fd(c.err);
                    break;
            }
        }
    }
    return done;
}

void CommandPool::reap(const std::function<void(Child&, int)>& on_exit) {
    for (std::size_t i = 0; i < children_.size();) {
        int status = 0;
        const pid_t r = ::waitpid(children_[i].pid, &status, WNOHANG);
        if (r == children_[i].pid || (r < 0 && errno == ECHILD)) {
            on_exit(children_[i], r < 0 ? 0 : status);
            children_.erase(children_.begin() + static_cast<std::ptrdiff_t>(i));
        } else {
            ++i;
        }
    }
}

void CommandPool::kill_all() {
    for (auto& c : children_) ::kill(-c.pid, SIGTERM);
    const double until = now_s() + kKillGrace;
    while (!children_.empty()) {
        reap([](Child& c, int) {
            close_fd(c.in);
            close_fd(c.out);
            close_fd(c.err);
        });
        if (children_.empty()) break;
        if (now_s() > until) {
            for (auto& c : children_) ::kill(-c.pid, SIGKILL);
        }
        ::usleep(20000);
    }
}

}  // namespace maptune::tuning
