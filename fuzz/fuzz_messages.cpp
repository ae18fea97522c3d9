// What arrives over DDS: CDR bytes deserialized into each message type (the first byte picks
// it), then the boundary check (dds::check) and, for messages that pass, the conversion into
// maptune's own types — the path every service takes.
#include <exception>
#include <vector>

#include <fastdds/rtps/common/SerializedPayload.h>

#include "dds/convert.hpp"
#include "dds/validate.hpp"
#include "maptunePubSubTypes.h"

namespace {

namespace v1 = maptune::msg::v1;

template <class PubSub, class After>
void decode(const std::uint8_t* data, std::size_t size, After after) {
    PubSub type;
    eprosima::fastrtps::rtps::SerializedPayload_t payload(static_cast<std::uint32_t>(size));
    std::copy(data, data + size, payload.data);
    payload.length = static_cast<std::uint32_t>(size);
    typename PubSub::type msg;
    if (!type.deserialize(&payload, &msg)) return;
    if (!maptune::dds::check(msg).empty()) return;
    after(msg);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const std::uint8_t* d = data + 1;
    const std::size_t n = size - 1;
    try {
        switch (data[0] % 8) {
            case 0:
                decode<v1::ObservationRequestPubSubType>(
                    d, n, [](const v1::ObservationRequest& m) { (void)maptune::dds::from_msg(m.params()); });
                break;
            case 1:
                decode<v1::ObservationReplyPubSubType>(d, n, [](const v1::ObservationReply& m) {
                    (void)maptune::dds::from_msg(m.params());
                    (void)maptune::dds::from_msg(m.pairs());
                });
                break;
            case 2:
                decode<v1::EvaluationTaskPubSubType>(
                    d, n, [](const v1::EvaluationTask& m) { (void)maptune::dds::from_msg(m.params()); });
                break;
            case 3:
                decode<v1::TaskResultPubSubType>(d, n,
                                                 [](const v1::TaskResult& m) { (void)maptune::dds::from_msg(m.pairs()); });
                break;
            case 4: decode<v1::WorkerStatusPubSubType>(d, n, [](const v1::WorkerStatus&) {}); break;
            case 5: decode<v1::DatasetAnnouncementPubSubType>(d, n, [](const v1::DatasetAnnouncement&) {}); break;
            case 6: decode<v1::FileChunkPubSubType>(d, n, [](const v1::FileChunk&) {}); break;
            default: decode<v1::BestSoFarPubSubType>(d, n, [](const v1::BestSoFar&) {});
        }
    } catch (const std::exception&) {
    }
    return 0;
}
