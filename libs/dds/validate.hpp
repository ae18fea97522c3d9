#pragma once
// The form of every incoming message, checked where it enters a service (issue 14): sizes of
// strings and sequences, finite numbers, known enum values, consistent counts. What a message
// *means* (a known design space, parameters within bounds, the right pairs for a task) is the
// receiving service's check. Each function returns "" for a well-formed message, else
// "<field>: <what is wrong>" naming the first problem found.

#include <cstddef>
#include <string>

#include "maptune.h"

namespace maptune::dds {

struct MessageLimits {
    static constexpr std::size_t kId = 1024;            // ids, names, hashes, views, paths
    static constexpr std::size_t kText = 64 * 1024;     // error, reason and status texts
    static constexpr std::size_t kParams = 256;         // named values of one set
    static constexpr std::size_t kSettings = 1024;      // matcher settings of one request
    static constexpr std::size_t kPairs = 2'000'000;    // pairs of one view (the full moon: 31 200)
    static constexpr std::size_t kTasks = 100'000;      // task ids a worker lists
    static constexpr std::size_t kFiles = 1'000'000;    // files of one dataset
    static constexpr std::size_t kChunk = 64u << 20;    // bytes of one file chunk
    static constexpr unsigned kChunks = 1u << 20;       // chunks of one file (512 GB at 512 KiB)
    static constexpr unsigned kSlots = 4096;            // tasks a worker runs at once
};

std::string check(const msg::v1::ObservationRequest& m);
std::string check(const msg::v1::ObservationReply& m);
std::string check(const msg::v1::EvaluationTask& m);
std::string check(const msg::v1::TaskResult& m);
std::string check(const msg::v1::WorkerStatus& m);
std::string check(const msg::v1::DatasetAnnouncement& m);
std::string check(const msg::v1::FileRequest& m);
std::string check(const msg::v1::FileChunk& m);
std::string check(const msg::v1::BestSoFar& m);
std::string check(const msg::v1::OptimizerStatus& m);

}  // namespace maptune::dds
