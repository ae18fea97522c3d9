#include "dds/convert.hpp"

namespace maptune::dds {

namespace v1 = msg::v1;

std::vector<v1::NamedValue> to_msg(const params::ParameterSet& set) {
    std::vector<v1::NamedValue> out;
    for (const auto& [name, value] : set) {
        v1::NamedValue nv;
        nv.name(name);
        nv.value(value);
        out.push_back(nv);
    }
    return out;
}

params::ParameterSet from_msg(const std::vector<v1::NamedValue>& values) {
    params::ParameterSet set;
    for (const auto& nv : values) set.set(nv.name(), nv.value());
    return set;
}

v1::PairResult to_msg(const store::PairRecord& r) {
    v1::PairResult m;
    m.pair_id(r.pair_id);
    m.matched(r.matched);
    for (int i = 0; i < 16; ++i) m.t_a_b()[static_cast<std::size_t>(i)] = r.T_a_b_est(i / 4, i % 4);
    m.duration_s(r.duration_s);
    switch (r.status) {
        case store::PairStatus::kOk: m.status(v1::PAIR_OK); break;
        case store::PairStatus::kNoMatch: m.status(v1::PAIR_NO_MATCH); break;
        case store::PairStatus::kFailed: m.status(v1::PAIR_FAILED); break;
        case store::PairStatus::kTimeout: m.status(v1::PAIR_TIMEOUT); break;
    }
    m.reason(r.reason);
    return m;
}

store::PairRecord from_msg(const v1::PairResult& m) {
    store::PairRecord r;
    r.pair_id = m.pair_id();
    r.matched = m.matched();
    for (int i = 0; i < 16; ++i) r.T_a_b_est(i / 4, i % 4) = m.t_a_b()[static_cast<std::size_t>(i)];
    r.duration_s = m.duration_s();
    switch (m.status()) {
        case v1::PAIR_OK: r.status = store::PairStatus::kOk; break;
        case v1::PAIR_NO_MATCH: r.status = store::PairStatus::kNoMatch; break;
        case v1::PAIR_FAILED: r.status = store::PairStatus::kFailed; break;
        case v1::PAIR_TIMEOUT: r.status = store::PairStatus::kTimeout; break;
    }
    r.reason = m.reason();
    return r;
}

std::vector<v1::PairResult> to_msg(const std::vector<store::PairRecord>& records) {
    std::vector<v1::PairResult> out;
    out.reserve(records.size());
    for (const auto& r : records) out.push_back(to_msg(r));
    return out;
}

std::vector<store::PairRecord> from_msg(const std::vector<v1::PairResult>& results) {
    std::vector<store::PairRecord> out;
    out.reserve(results.size());
    for (const auto& m : results) out.push_back(from_msg(m));
    return out;
}

}  // namespace maptune::dds
