#pragma once
// Messages refused at a service's boundary (dds::check): the reason is logged the first time
// per topic and field, then only counted — a sender repeating a bad message cannot flood the
// log, and the service keeps serving.

#include <functional>
#include <iostream>
#include <mutex>
#include <set>
#include <string>

namespace maptune::services {

class RefusalLog {
public:
    using Log = std::function<void(const std::string&)>;
    // `who` prefixes the default stderr line; `log` replaces it (a service's own log).
    explicit RefusalLog(std::string who, Log log = {}) : who_(std::move(who)), log_(std::move(log)) {}

    // Records one refused message on `topic` from `sender`; `reason` is "<field>: <why>".
    void refused(const std::string& topic, const std::string& sender, const std::string& reason) {
        const std::string field = reason.substr(0, reason.find(':'));
        bool first = false;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            ++count_;
            first = seen_.insert(topic + "\n" + field).second;
        }
        if (!first) return;
        const std::string line = "refused a " + topic + " message" +
                                 (sender.empty() ? "" : " from '" + sender.substr(0, 128) + "'") + ": " + reason +
                                 " (logged once per field; later ones are only counted)";
        if (log_) {
            log_(line);
        } else {
            std::cerr << who_ << ": " << line << std::endl;
        }
    }
    std::size_t count() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return count_;
    }

private:
    std::string who_;
    Log log_;
    mutable std::mutex mutex_;
    std::set<std::string> seen_;
    std::size_t count_ = 0;
};

}  // namespace maptune::services
