// Test peer: answers every ObservationRequest with an ObservationReply whose error echoes the
// requester, until SIGINT/SIGTERM; then deletes its participant and exits 0.
#include <csignal>
#include <cstdlib>
#include <iostream>
#include <thread>

#include "dds/participant.hpp"
#include "maptunePubSubTypes.h"

namespace {
volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }
}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::cerr << "usage: dds_echo DOMAIN_ID\n";
        return 2;
    }
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    namespace v1 = maptune::msg::v1;
    try {
        maptune::dds::Participant participant({std::atoi(argv[1]), "", "maptune_loopback", "dds_echo"});
        auto replies = participant.writer<v1::ObservationReplyPubSubType>(
            "maptune/observation_reply", maptune::dds::TopicQos::kReliable);
        const auto requests_sub = participant.reader<v1::ObservationRequestPubSubType>(
            "maptune/observation_request", maptune::dds::TopicQos::kReliable,
            [&replies](const v1::ObservationRequest& req) {
                v1::ObservationReply rep;
                rep.request_id(req.request_id());
                rep.ok(true);
                rep.error("echo:" + req.requester());
                rep.params(req.params());
                replies.write(rep);
            });
        std::cout << "ready" << std::endl;
        while (g_stop == 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    } catch (const std::exception& e) {
        std::cerr << "dds_echo: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
