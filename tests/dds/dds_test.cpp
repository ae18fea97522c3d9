#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <arpa/inet.h>

#include <atomic>
#include <fstream>
#include <map>
#include <sstream>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include "test_domain.hpp"
#include "wait_until.hpp"
#include "dds/convert.hpp"
#include "dds/domain_lease.hpp"
#include "dds/participant.hpp"
#include "fastdds_shm.hpp"
#include "maptunePubSubTypes.h"

extern char** environ;

namespace maptune::dds {
namespace {

namespace v1 = maptune::msg::v1;
using namespace std::chrono_literals;

int random_domain() { return test::reserve_domain(); }

using test::wait_until;

// Leases are host-wide: what this process holds another cannot take (the `flock` command, as
// scripts/fault-test.sh takes them), a lease held elsewhere is refused, a full range throws.
// Domains 201..206 lie outside every random range maptune uses.
TEST(DomainLease, HeldDomainsAreNeverHandedOutTwice) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "maptune-dds-domains";
    const int d = lease_random_domain(1, 200);
    EXPECT_TRUE(lease_domain(d));  // already ours
    const std::string probe = "flock -n -E 7 " + (dir / (std::to_string(d) + ".lock")).string() + " true";
    EXPECT_EQ(WEXITSTATUS(std::system(probe.c_str())), 7) << probe;

    // Another holder of 206 (a second open file description conflicts as another process would).
    const int other = ::open((dir / "206.lock").c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0666);
    ASSERT_GE(other, 0);
    const bool held_elsewhere = ::flock(other, LOCK_EX | LOCK_NB) == 0;
    if (held_elsewhere) {
        EXPECT_FALSE(lease_domain(206));
    }
    std::set<int> got;
    for (int i = 0; i < 5; ++i) got.insert(lease_random_domain(201, 205));
    EXPECT_EQ(got, (std::set<int>{201, 202, 203, 204, 205}));
    EXPECT_THROW(lease_random_domain(201, 205), std::runtime_error);
    ::close(other);
    EXPECT_TRUE(held_elsewhere) << "domain 206 was held by another process";
}

// Local addresses (host byte order) of the UDP sockets this process owns, from /proc.
std::vector<uint32_t> own_udp_addresses() {
    std::set<std::string> inodes;
    for (const auto& e : std::filesystem::directory_iterator("/proc/self/fd")) {
        std::error_code ec;
        const auto target = std::filesystem::read_symlink(e.path(), ec).string();
        if (target.rfind("socket:[", 0) == 0) inodes.insert(target.substr(8, target.size() - 9));
    }
    std::vector<uint32_t> out;
    std::ifstream udp("/proc/self/net/udp");
    std::string line;
    std::getline(udp, line);  // header
    while (std::getline(udp, line)) {
        std::istringstream f(line);
        std::string sl, local, remote, st, queues, tr, retr, uid, timeout, inode;
        f >> sl >> local >> remote >> st >> queues >> tr >> retr >> uid >> timeout >> inode;
        if (!inodes.count(inode)) continue;
        // "0100007F:1F90": little-endian hex address as the kernel stores it.
        const uint32_t raw = static_cast<uint32_t>(std::stoul(local.substr(0, 8), nullptr, 16));
        out.push_back(ntohl(raw));
    }
    return out;
}

TEST(Participant, DefaultProfileBindsOnlyLoopbackSockets) {
    Participant p({random_domain(), "", "maptune_loopback", "socket_check"});
    p.writer<v1::BestSoFarPubSubType>("t/best_sockets", TopicQos::kLatched);  // opens data sockets
    const auto addresses = own_udp_addresses();
    ASSERT_FALSE(addresses.empty()) << "expected UDP sockets for loopback discovery";
    for (uint32_t a : addresses) {
        EXPECT_EQ(a >> 24, 127u) << "UDP socket bound to " << (a >> 24) << "." << ((a >> 16) & 255)
                                 << "." << ((a >> 8) & 255) << "." << (a & 255);
    }
}

TEST(Participant, RejectsOutOfRangeDomainAndUnknownProfile) {
    EXPECT_THROW(Participant({233, "", "maptune_loopback", "t"}), DdsError);
    EXPECT_THROW(Participant({-1, "", "maptune_loopback", "t"}), DdsError);
    EXPECT_THROW(Participant({1, "", "no_such_profile", "t"}), DdsError);
    EXPECT_THROW(Participant({1, "/nonexistent/profiles.xml", "maptune_loopback", "t"}), DdsError);
}

// The wire contract's QoS (docs/plugin-matcher.md) comes from configs/dds/qos.xml, compiled
// in: with the built-in profile and with a user's profile file alike.
TEST(Participant, TopicQosComesFromTheShippedProfiles) {
    namespace fd = eprosima::fastdds::dds;
    // A user's file: a loopback participant profile of its own name, no QoS in it.
    const auto dir = std::filesystem::temp_directory_path() / ("maptune_qos_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string user_file = (dir / "user.xml").string();
    std::ofstream(user_file) << R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"><profiles>
  <transport_descriptors><transport_descriptor>
    <transport_id>user_udp</transport_id><type>UDPv4</type>
    <interfaceWhiteList><address>127.0.0.1</address></interfaceWhiteList>
  </transport_descriptor></transport_descriptors>
  <participant profile_name="user_loopback"><rtps>
    <useBuiltinTransports>false</useBuiltinTransports>
    <userTransports><transport_id>user_udp</transport_id></userTransports>
    <builtin>
      <metatrafficUnicastLocatorList><locator><udpv4><address>127.0.0.1</address></udpv4></locator></metatrafficUnicastLocatorList>
      <initialPeersList><locator><udpv4><address>127.0.0.1</address></udpv4></locator></initialPeersList>
    </builtin>
  </rtps></participant>
</profiles></dds>
)";
    for (const std::string& file : {std::string(), user_file}) {
        SCOPED_TRACE(file.empty() ? "built-in loopback profile" : "a user's profile file");
        Participant p({random_domain(), file, file.empty() ? "maptune_loopback" : "user_loopback", "qos_check"});
        struct Want {
            TopicQos qos;
            fd::ReliabilityQosPolicyKind reliability;
            fd::DurabilityQosPolicyKind durability;
            int depth;
        };
        for (const auto& w : {Want{TopicQos::kReliable, fd::RELIABLE_RELIABILITY_QOS, fd::VOLATILE_DURABILITY_QOS, 1000},
                              Want{TopicQos::kLatched, fd::RELIABLE_RELIABILITY_QOS, fd::TRANSIENT_LOCAL_DURABILITY_QOS, 1},
                              Want{TopicQos::kBestEffort, fd::BEST_EFFORT_RELIABILITY_QOS, fd::VOLATILE_DURABILITY_QOS, 1}}) {
            const auto wq = p.writer_qos(w.qos);
            const auto rq = p.reader_qos(w.qos);
            EXPECT_EQ(wq.reliability().kind, w.reliability) << qos_profile(w.qos, true);
            EXPECT_EQ(rq.reliability().kind, w.reliability) << qos_profile(w.qos, false);
            EXPECT_EQ(wq.durability().kind, w.durability);
            EXPECT_EQ(rq.durability().kind, w.durability);
            for (const auto& h : {wq.history(), rq.history()}) {
                EXPECT_EQ(h.kind, fd::KEEP_LAST_HISTORY_QOS);
                EXPECT_EQ(h.depth, w.depth);
            }
            for (const auto& l : {wq.resource_limits(), rq.resource_limits()}) {
                EXPECT_EQ(l.max_instances, 4096);
                EXPECT_EQ(l.max_samples_per_instance, w.depth);
                EXPECT_EQ(l.max_samples, 4096);
            }
        }
    }
    std::filesystem::remove_all(dir);
}

TEST(Participant, ReliableRequestsArriveInOrderBetweenParticipants) {
    const int domain = random_domain();
    Participant a({domain, "", "maptune_loopback", "a"});
    Participant b({domain, "", "maptune_loopback", "b"});
    std::mutex m;
    std::vector<std::string> got;
    const auto requests_sub = b.reader<v1::ObservationRequestPubSubType>("t/requests", TopicQos::kReliable,
                                              [&](const v1::ObservationRequest& r) {
                                                  std::lock_guard<std::mutex> lock(m);
                                                  got.push_back(r.request_id());
                                              });
    auto w = a.writer<v1::ObservationRequestPubSubType>("t/requests", TopicQos::kReliable);
    ASSERT_TRUE(w.wait_for_readers(1, 10s)) << "no discovery on loopback, domain " << domain;
    for (int i = 0; i < 200; ++i) {
        v1::ObservationRequest r;
        r.request_id("req-" + std::to_string(i));
        r.params().push_back(v1::NamedValue());
        r.params().back().name("r_N");
        r.params().back().value(0.01 * i);
        ASSERT_TRUE(w.write(r)) << "sample " << i;
    }
    ASSERT_TRUE(wait_until([&] { std::lock_guard<std::mutex> l(m); return got.size() == 200; }, 10s));
    for (int i = 0; i < 200; ++i) EXPECT_EQ(got[static_cast<std::size_t>(i)], "req-" + std::to_string(i));
}

// Tasks go only to their assignee's filtered reader (kTaskAssigneeMember must name
// EvaluationTask's worker_id), in order, reliably; an unfiltered reader still gets every task.
TEST(Participant, FilteredReaderGetsOnlyItsWorkersTasks) {
    const int domain = random_domain();
    Participant db({domain, "", "maptune_loopback", "db"});
    Participant p1({domain, "", "maptune_loopback", "p1"});
    Participant p2({domain, "", "maptune_loopback", "p2"});
    Participant all({domain, "", "maptune_loopback", "all"});
    const std::vector<std::string> ids = {"w-1", "w'2 \"quoted\" ü", "w-3"};  // w-3 has no reader
    std::mutex m;
    std::map<std::string, std::vector<std::string>> got;  // reader -> task ids
    auto keep = [&](const std::string& reader) {
        return [&, reader](const v1::EvaluationTask& t) {
            std::lock_guard<std::mutex> lock(m);
            got[reader].push_back(t.task_id() + "@" + t.worker_id());
        };
    };
    const auto s1 = p1.reader_where<v1::EvaluationTaskPubSubType>("t/tasks", TopicQos::kReliable, topics::kTaskAssigneeMember, ids[0], keep("r1"));
    const auto s2 = p2.reader_where<v1::EvaluationTaskPubSubType>("t/tasks", TopicQos::kReliable, topics::kTaskAssigneeMember, ids[1], keep("r2"));
    const auto s3 = all.reader<v1::EvaluationTaskPubSubType>("t/tasks", TopicQos::kReliable, keep("all"));
    auto w = db.writer<v1::EvaluationTaskPubSubType>("t/tasks", TopicQos::kReliable);
    ASSERT_TRUE(w.wait_for_readers(3, 10s)) << "no discovery on loopback, domain " << domain;
    std::map<std::string, std::vector<std::string>> want;
    for (int i = 0; i < 90; ++i) {
        v1::EvaluationTask t;
        t.task_id("task-" + std::to_string(i));
        const std::string& id = ids[static_cast<std::size_t>(i) % ids.size()];
        t.worker_id(id);
        t.pair_ids().push_back("run00/submap000:run00/submap001");
        ASSERT_TRUE(w.write(t)) << "task " << i;
        want["all"].push_back(t.task_id() + "@" + id);
        if (id == ids[0]) want["r1"].push_back(t.task_id() + "@" + id);
        if (id == ids[1]) want["r2"].push_back(t.task_id() + "@" + id);
    }
    ASSERT_TRUE(wait_until([&] { std::lock_guard<std::mutex> l(m); return got["all"].size() == 90; }, 10s));
    ASSERT_TRUE(wait_until([&] {
        std::lock_guard<std::mutex> l(m);
        return got["r1"].size() >= 30 && got["r2"].size() >= 30;
    }, 10s));
    std::this_thread::sleep_for(200ms);  // room for a sample that should not come
    std::lock_guard<std::mutex> l(m);
    EXPECT_EQ(got["r1"], want["r1"]);
    EXPECT_EQ(got["r2"], want["r2"]);
    EXPECT_EQ(got["all"], want["all"]);
}

// A service's callbacks must never run once it is being destroyed, though its participant
// lives on: destroying the Subscription waits for a running callback and stops later ones.
TEST(Participant, DestroyedSubscriptionWaitsForItsCallbackAndStopsFurtherOnes) {
    const int domain = random_domain();
    Participant a({domain, "", "maptune_loopback", "a"});
    Participant b({domain, "", "maptune_loopback", "b"});
    std::atomic<int> started{0}, finished{0};
    auto sub = std::make_unique<Subscription>(b.reader<v1::ObservationRequestPubSubType>(
        "t/gate", TopicQos::kReliable, [&](const v1::ObservationRequest&) {
            ++started;
            std::this_thread::sleep_for(std::chrono::milliseconds(300));
            ++finished;
        }));
    auto w = a.writer<v1::ObservationRequestPubSubType>("t/gate", TopicQos::kReliable);
    ASSERT_TRUE(w.wait_for_readers(1, 10s));
    v1::ObservationRequest r;
    r.request_id("one");
    ASSERT_TRUE(w.write(r));
    ASSERT_TRUE(wait_until([&] { return started.load() == 1; }, 10s));
    sub.reset();  // while the callback sleeps
    EXPECT_EQ(finished.load(), 1) << "the subscription went away under a running callback";
    // A second reader proves the next samples were delivered; the closed one saw none.
    std::atomic<int> witnessed{0};
    const auto witness = b.reader<v1::ObservationRequestPubSubType>("t/gate", TopicQos::kReliable,
                                                                    [&](const v1::ObservationRequest&) { ++witnessed; });
    ASSERT_TRUE(w.wait_for_readers(2, 10s));
    for (int i = 0; i < 5; ++i) ASSERT_TRUE(w.write(r));
    ASSERT_TRUE(wait_until([&] { return witnessed.load() == 5; }, 10s));
    EXPECT_EQ(started.load(), 1);
}

TEST(Participant, LatchedTopicGivesALateSubscriberOnlyTheLatestSample) {
    const int domain = random_domain();
    Participant pub({domain, "", "maptune_loopback", "pub"});
    auto w = pub.writer<v1::BestSoFarPubSubType>("t/best", TopicQos::kLatched);
    for (int i = 1; i <= 5; ++i) {
        v1::BestSoFar b;
        b.experiment_id("exp");
        b.evaluations(static_cast<uint32_t>(i));
        b.best_p(0.1 * i);
        ASSERT_TRUE(w.write(b));
    }
    Participant late({domain, "", "maptune_loopback", "late"});
    std::mutex m;
    std::vector<double> seen;
    const auto best_sub = late.reader<v1::BestSoFarPubSubType>("t/best", TopicQos::kLatched, [&](const v1::BestSoFar& b) {
        std::lock_guard<std::mutex> lock(m);
        seen.push_back(b.best_p());
    });
    ASSERT_TRUE(wait_until([&] { std::lock_guard<std::mutex> l(m); return !seen.empty(); }, 10s));
    std::this_thread::sleep_for(200ms);  // would let stale samples arrive, if there were any
    std::lock_guard<std::mutex> lock(m);
    ASSERT_EQ(seen.size(), 1u);
    EXPECT_DOUBLE_EQ(seen[0], 0.5);
}

TEST(Participant, TalksToAnotherProcessAndThatProcessStopsCleanlyOnSigterm) {
    const int domain = random_domain();
    const auto shm_before = maptune::testing::fastdds_shm_files();
    const std::string domain_text = std::to_string(domain);
    char* argv[] = {const_cast<char*>(MAPTUNE_DDS_ECHO), const_cast<char*>(domain_text.c_str()), nullptr};
    pid_t pid = 0;
    ASSERT_EQ(posix_spawn(&pid, MAPTUNE_DDS_ECHO, nullptr, nullptr, argv, environ), 0);
    struct Reaper {  // the child is stopped whatever happens below
        pid_t pid;
        ~Reaper() {
            if (pid > 0) {
                kill(pid, SIGKILL);
                waitpid(pid, nullptr, 0);
            }
        }
    } reaper{pid};
    {
        Participant me({domain, "", "maptune_loopback", "test"});
        std::mutex m;
        std::vector<v1::ObservationReply> replies;
        const auto replies_sub = me.reader<v1::ObservationReplyPubSubType>("maptune/observation_reply", TopicQos::kReliable,
                                                 [&](const v1::ObservationReply& r) {
                                                     std::lock_guard<std::mutex> lock(m);
                                                     replies.push_back(r);
                                                 });
        auto w = me.writer<v1::ObservationRequestPubSubType>("maptune/observation_request",
                                                            TopicQos::kReliable);
        ASSERT_TRUE(w.wait_for_readers(1, 15s));
        v1::ObservationRequest req;
        req.request_id("r1");
        req.requester("dds_test");
        v1::NamedValue nv;
        nv.name("n_TF");
        nv.value(63);
        req.params().push_back(nv);
        // The echo's reply writer may match our reader slightly after its reader matched us.
        ASSERT_TRUE(wait_until(
            [&] {
                std::lock_guard<std::mutex> l(m);
                if (replies.empty()) w.write(req);
                return !replies.empty();
            },
            15s));
        std::lock_guard<std::mutex> lock(m);
        EXPECT_EQ(replies[0].request_id(), "r1");
        EXPECT_EQ(replies[0].error(), "echo:dds_test");
        ASSERT_EQ(replies[0].params().size(), 1u);
        EXPECT_EQ(replies[0].params()[0].value(), 63);
    }
    ASSERT_EQ(kill(pid, SIGTERM), 0);
    int status = 0;
    ASSERT_TRUE(wait_until([&] { return waitpid(pid, &status, WNOHANG) == pid; }, 10s));
    reaper.pid = 0;
    EXPECT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);
    // A clean shutdown leaves no shared-memory segment behind.
    std::set<std::string> leaked;
    for (const auto& f : maptune::testing::fastdds_shm_files()) {
        if (!shm_before.count(f)) leaked.insert(f);
    }
    EXPECT_TRUE(leaked.empty()) << "leaked " << *leaked.begin();
}

}  // namespace
}  // namespace maptune::dds
