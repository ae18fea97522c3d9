#pragma once
// The one place where DDS messages and core types convert into each other, and the topic
// names (versioned with the IDL module).

#include <string>
#include <vector>

#include "maptune.h"
#include "params/parameter_set.hpp"
#include "store/observation_store.hpp"

namespace maptune::dds {

namespace topics {
inline constexpr const char* kObservationRequest = "maptune/v1/observation_request";
inline constexpr const char* kObservationReply = "maptune/v1/observation_reply";
inline constexpr const char* kEvaluationTask = "maptune/v1/evaluation_task";
inline constexpr const char* kTaskResult = "maptune/v1/task_result";
inline constexpr const char* kWorkerStatus = "maptune/v1/worker_status";
inline constexpr const char* kDatasetAnnouncement = "maptune/v1/dataset_announcement";
inline constexpr const char* kFileRequest = "maptune/v1/file_request";
inline constexpr const char* kFileChunk = "maptune/v1/file_chunk";
inline constexpr const char* kBestSoFar = "maptune/v1/best_so_far";
inline constexpr const char* kOptimizerStatus = "maptune/v1/optimizer_status";
// EvaluationTask's worker_id is its second string member (idl/maptune.idl): what workers'
// task filters compare (Participant::reader_where; Participant.FilteredReaderGetsOnlyItsWorkersTasks).
inline constexpr int kTaskAssigneeMember = 1;
}  // namespace topics

std::vector<msg::v1::NamedValue> to_msg(const params::ParameterSet& set);
params::ParameterSet from_msg(const std::vector<msg::v1::NamedValue>& values);

msg::v1::PairResult to_msg(const store::PairRecord& record);
store::PairRecord from_msg(const msg::v1::PairResult& result);
std::vector<msg::v1::PairResult> to_msg(const std::vector<store::PairRecord>& records);
std::vector<store::PairRecord> from_msg(const std::vector<msg::v1::PairResult>& results);

}  // namespace maptune::dds
