#include "dds/validate.hpp"

#include <cmath>
#include <vector>

namespace maptune::dds {

namespace v1 = msg::v1;
using L = MessageLimits;

namespace {

// Collects the first problem; later checks are skipped once one is found.
class Checker {
public:
    Checker& text(const char* field, const std::string& s, std::size_t max) {
        if (error_.empty() && s.size() > max) {
            error_ = std::string(field) + ": " + std::to_string(s.size()) + " characters (at most " +
                     std::to_string(max) + ")";
        }
        return *this;
    }
    Checker& id(const char* field, const std::string& s) { return text(field, s, L::kId); }
    Checker& finite(const char* field, double v) {
        if (error_.empty() && !std::isfinite(v)) error_ = std::string(field) + ": not a finite number";
        return *this;
    }
    Checker& nonnegative(const char* field, double v) {
        finite(field, v);
        if (error_.empty() && v < 0) error_ = std::string(field) + ": negative";
        return *this;
    }
    template <class Seq>
    Checker& count(const char* field, const Seq& seq, std::size_t max) {
        if (error_.empty() && seq.size() > max) {
            error_ = std::string(field) + ": " + std::to_string(seq.size()) + " entries (at most " +
                     std::to_string(max) + ")";
        }
        return *this;
    }
    Checker& ids(const char* field, const std::vector<std::string>& seq, std::size_t max) {
        count(field, seq, max);
        for (const auto& s : seq) {
            if (!error_.empty()) break;
            id(field, s);
        }
        return *this;
    }
    Checker& values(const char* field, const std::vector<v1::NamedValue>& seq) {
        count(field, seq, L::kParams);
        for (const auto& nv : seq) {
            if (!error_.empty()) break;
            text(field, nv.name(), L::kId);
            if (error_.empty() && !std::isfinite(nv.value())) {
                error_ = std::string(field) + ": " + nv.name().substr(0, 64) + " is not a finite number";
            }
        }
        return *this;
    }
    Checker& pairs(const char* field, const std::vector<v1::PairResult>& seq) {
        count(field, seq, L::kPairs);
        for (const auto& p : seq) {
            if (!error_.empty()) break;
            id("pairs.pair_id", p.pair_id());
            text("pairs.reason", p.reason(), L::kText);
            for (double v : p.t_a_b()) finite("pairs.t_a_b", v);
            nonnegative("pairs.duration_s", p.duration_s());
            const auto s = static_cast<long long>(p.status());
            if (error_.empty() && (s < v1::PAIR_OK || s > v1::PAIR_TIMEOUT)) {
                error_ = "pairs.status: unknown value " + std::to_string(s);
            }
        }
        return *this;
    }
    Checker& require(bool ok, const std::string& what) {
        if (error_.empty() && !ok) error_ = what;
        return *this;
    }
    std::string result() const { return error_; }

private:
    std::string error_;
};

}  // namespace

std::string check(const v1::ObservationRequest& m) {
    return Checker()
        .id("request_id", m.request_id())
        .id("requester", m.requester())
        .id("dataset_id", m.dataset_id())
        .id("view", m.view())
        .id("matcher_id", m.matcher_id())
        .id("matcher_version", m.matcher_version())
        .id("space_hash", m.space_hash())
        .values("params", m.params())
        .ids("matcher_settings", m.matcher_settings(), L::kSettings)
        .result();
}

std::string check(const v1::ObservationReply& m) {
    return Checker()
        .id("request_id", m.request_id())
        .text("error", m.error(), L::kText)
        .text("params_key", m.params_key(), L::kText)
        .values("params", m.params())
        .pairs("pairs", m.pairs())
        .nonnegative("wall_seconds", m.wall_seconds())
        .result();
}

std::string check(const v1::EvaluationTask& m) {
    return Checker()
        .id("task_id", m.task_id())
        .id("worker_id", m.worker_id())
        .id("dataset_id", m.dataset_id())
        .id("view", m.view())
        .id("matcher_id", m.matcher_id())
        .id("space_hash", m.space_hash())
        .values("params", m.params())
        .ids("pair_ids", m.pair_ids(), L::kPairs)
        .require(!m.pair_ids().empty(), "pair_ids: empty")
        .id("matcher_version", m.matcher_version())
        .ids("matcher_settings", m.matcher_settings(), L::kSettings)
        .result();
}

std::string check(const v1::TaskResult& m) {
    return Checker()
        .id("task_id", m.task_id())
        .id("worker_id", m.worker_id())
        .text("error", m.error(), L::kText)
        .pairs("pairs", m.pairs())
        .result();
}

std::string check(const v1::WorkerStatus& m) {
    return Checker()
        .id("worker_id", m.worker_id())
        .require(!m.worker_id().empty(), "worker_id: empty")
        .id("matcher_id", m.matcher_id())
        .id("matcher_version", m.matcher_version())
        .id("space_hash", m.space_hash())
        .require(m.slots() >= 1 && m.slots() <= L::kSlots,
                 "slots: " + std::to_string(m.slots()) + " (1.." + std::to_string(L::kSlots) + ")")
        .require(m.busy() <= m.slots(), "busy: " + std::to_string(m.busy()) + " of " + std::to_string(m.slots()) + " slots")
        .ids("tasks", m.tasks(), L::kTasks)
        .result();
}

std::string check(const v1::DatasetAnnouncement& m) {
    Checker c;
    c.id("dataset_id", m.dataset_id())
        .require(!m.dataset_id().empty(), "dataset_id: empty")
        .id("name", m.name())
        .id("server_id", m.server_id())
        .count("files", m.files(), L::kFiles);
    for (const auto& f : m.files()) {
        c.id("files.path", f.path()).id("files.hash", f.hash());
    }
    return c.result();
}

std::string check(const v1::FileRequest& m) {
    return Checker().id("request_id", m.request_id()).id("dataset_id", m.dataset_id()).id("path", m.path()).result();
}

std::string check(const v1::FileChunk& m) {
    return Checker()
        .id("request_id", m.request_id())
        .id("path", m.path())
        .require(m.count() >= 1 && m.count() <= L::kChunks,
                 "count: " + std::to_string(m.count()) + " (1.." + std::to_string(L::kChunks) + ")")
        .require(m.index() < m.count(), "index: " + std::to_string(m.index()) + " of " + std::to_string(m.count()))
        .count("data", m.data(), L::kChunk)
        .text("error", m.error(), L::kText)
        .result();
}

std::string check(const v1::BestSoFar& m) {
    return Checker()
        .id("experiment_id", m.experiment_id())
        .finite("best_p", m.best_p())
        .values("best_params", m.best_params())
        .finite("predicted_mean", m.predicted_mean())
        .finite("predicted_std", m.predicted_std())
        .values("predicted_params", m.predicted_params())
        .result();
}

std::string check(const v1::OptimizerStatus& m) {
    return Checker()
        .id("experiment_id", m.experiment_id())
        .id("state", m.state())
        .values("gp_hyperparameters", m.gp_hyperparameters())
        .text("message", m.message(), L::kText)
        .result();
}

}  // namespace maptune::dds
