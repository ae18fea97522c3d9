// DDS-Security with the material of scripts/make-pki.sh: who may talk to whom. Every check
// that something does NOT arrive is paired with one that the same path works for a peer
// that is allowed, in the same domain at the same time — so the test fails if security is
// simply broken (nothing arrives for anyone) or simply off (everything arrives).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <thread>

#include "dds/convert.hpp"
#include "dds/participant.hpp"
#include "maptunePubSubTypes.h"
#include "test_domain.hpp"
#include "wait_until.hpp"

namespace maptune::dds {
namespace {

namespace fs = std::filesystem;
namespace v1 = maptune::msg::v1;
using namespace std::chrono_literals;

using test::wait_until;

void run_or_fail(const std::string& command) {
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
}

// Two independent PKIs (A: the deployment's, B: someone else's CA) and an expired worker
// identity in A, made once for the whole suite by the shipped script.
class DdsSecurity : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        std::random_device rd;
        root_ = new fs::path(fs::temp_directory_path() / ("maptune-pki-" + std::to_string(rd())));
        const std::string script = MAPTUNE_MAKE_PKI;
        run_or_fail("bash " + script + " " + (*root_ / "a").string() + " >/dev/null");
        run_or_fail("bash " + script + " " + (*root_ / "b").string() + " >/dev/null");
        run_or_fail("bash " + script + " " + (*root_ / "a").string() +
                    " --add old_worker --role worker --expired >/dev/null");
    }
    static void TearDownTestSuite() {
        std::error_code ec;
        fs::remove_all(*root_, ec);
        delete root_;
    }

    ParticipantOptions secured(const std::string& pki, const std::string& identity) const {
        ParticipantOptions o;
        o.domain_id = domain_;
        o.name = "test_" + identity;
        o.security_dir = (*root_ / pki).string();
        o.identity = identity;
        return o;
    }
    ParticipantOptions plain(const std::string& name) const {
        ParticipantOptions o;
        o.domain_id = domain_;
        o.name = name;
        return o;
    }

    static v1::BestSoFar best(const std::string& experiment, double p) {
        v1::BestSoFar b;
        b.experiment_id(experiment);
        b.best_p(p);
        b.evaluations(1);
        return b;
    }
    static v1::TaskResult result(const std::string& task) {
        v1::TaskResult r;
        r.task_id(task);
        r.worker_id("w");
        r.ok(true);
        return r;
    }

    static fs::path* root_;
    int domain_ = test::reserve_domain();
};
fs::path* DdsSecurity::root_ = nullptr;

TEST_F(DdsSecurity, FilesAreCheckedBeforeFastDdsSeesThem) {
    auto o = secured("a", "nobody");
    try {
        Participant p(o);
        FAIL() << "an identity without files was accepted";
    } catch (const DdsError& e) {
        EXPECT_NE(std::string(e.what()).find("nobody/cert.pem is missing"), std::string::npos) << e.what();
    }
    o.identity.clear();
    EXPECT_THROW(Participant{o}, DdsError);
    EXPECT_TRUE(security_properties(plain("x")).empty());
}

TEST_F(DdsSecurity, RolesTalkAndAnUnauthenticatedRogueNeitherReadsNorWrites) {
    Participant optimizer(secured("a", "optimizer"));
    Participant watch(secured("a", "watch"));
    Participant sample_db(secured("a", "sample_db"));
    Participant worker(secured("a", "worker"));
    Participant rogue(plain("rogue"));

    std::atomic<int> watch_got{0}, rogue_got{0}, db_results{0}, db_rogue_results{0};
    auto best_w = optimizer.writer<v1::BestSoFarPubSubType>(topics::kBestSoFar, TopicQos::kLatched);
    auto s1 = watch.reader<v1::BestSoFarPubSubType>(topics::kBestSoFar, TopicQos::kLatched,
                                                    [&](const v1::BestSoFar&) { ++watch_got; });
    auto s2 = rogue.reader<v1::BestSoFarPubSubType>(topics::kBestSoFar, TopicQos::kLatched,
                                                    [&](const v1::BestSoFar&) { ++rogue_got; });
    auto s3 = sample_db.reader<v1::TaskResultPubSubType>(
        topics::kTaskResult, TopicQos::kReliable, [&](const v1::TaskResult& r) {
            (r.task_id() == "forged" ? db_rogue_results : db_results)++;
        });
    auto result_w = worker.writer<v1::TaskResultPubSubType>(topics::kTaskResult, TopicQos::kReliable);
    auto forged_w = rogue.writer<v1::TaskResultPubSubType>(topics::kTaskResult, TopicQos::kReliable);

    // The rogue forges results the whole time the legitimate traffic flows.
    ASSERT_TRUE(best_w.write(best("e", 0.5)));
    ASSERT_TRUE(wait_until(
        [&] {
            forged_w.write(result("forged"));
            result_w.write(result("real"));
            return watch_got > 0 && db_results > 0;
        },
        30s))
        << "authenticated roles did not reach each other (watch " << watch_got << ", sample_db " << db_results << ")";
    // Give the rogue as long again as the legitimate peers needed, and then some.
    const auto until = std::chrono::steady_clock::now() + 2s;
    while (std::chrono::steady_clock::now() < until) {
        forged_w.write(result("forged"));
        std::this_thread::sleep_for(50ms);
    }
    EXPECT_EQ(rogue_got, 0) << "an unauthenticated participant read best_so_far";
    EXPECT_EQ(db_rogue_results, 0) << "an unauthenticated participant's task_result was delivered";
    EXPECT_EQ(forged_w.matched(), 0);
    EXPECT_EQ(best_w.matched(), 1);  // the watch only, not the rogue
}

TEST_F(DdsSecurity, PermissionsLimitWhatEachRolePublishes) {
    Participant watch(secured("a", "watch"));
    Participant worker(secured("a", "worker"));
    Participant optimizer(secured("a", "optimizer"));
    EXPECT_THROW(watch.writer<v1::TaskResultPubSubType>(topics::kTaskResult, TopicQos::kReliable), DdsError);
    EXPECT_THROW(watch.writer<v1::BestSoFarPubSubType>(topics::kBestSoFar, TopicQos::kLatched), DdsError);
    try {
        worker.writer<v1::BestSoFarPubSubType>(topics::kBestSoFar, TopicQos::kLatched);
        FAIL() << "a worker identity may publish best_so_far";
    } catch (const DdsError& e) {
        EXPECT_NE(std::string(e.what()).find("identity 'worker' may not"), std::string::npos) << e.what();
    }
    EXPECT_THROW(optimizer.writer<v1::TaskResultPubSubType>(topics::kTaskResult, TopicQos::kReliable), DdsError);
    // What the roles do publish is allowed.
    EXPECT_NO_THROW(worker.writer<v1::TaskResultPubSubType>(topics::kTaskResult, TopicQos::kReliable));
    EXPECT_NO_THROW(optimizer.writer<v1::BestSoFarPubSubType>(topics::kBestSoFar, TopicQos::kLatched));
}

TEST_F(DdsSecurity, AnotherCasIdentityIsRefused) {
    Participant sample_db(secured("a", "sample_db"));
    Participant worker(secured("a", "worker"));
    Participant stranger(secured("b", "worker"));  // valid, but signed by B's CA
    std::atomic<int> real{0}, foreign{0};
    auto sub = sample_db.reader<v1::TaskResultPubSubType>(
        topics::kTaskResult, TopicQos::kReliable,
        [&](const v1::TaskResult& r) { (r.task_id() == "foreign" ? foreign : real)++; });
    auto good = worker.writer<v1::TaskResultPubSubType>(topics::kTaskResult, TopicQos::kReliable);
    auto bad = stranger.writer<v1::TaskResultPubSubType>(topics::kTaskResult, TopicQos::kReliable);
    ASSERT_TRUE(wait_until(
        [&] {
            bad.write(result("foreign"));
            good.write(result("real"));
            return real > 0;
        },
        30s));
    const auto until = std::chrono::steady_clock::now() + 2s;
    while (std::chrono::steady_clock::now() < until) {
        bad.write(result("foreign"));
        std::this_thread::sleep_for(50ms);
    }
    EXPECT_EQ(foreign, 0);
    EXPECT_EQ(bad.matched(), 0);
}

TEST_F(DdsSecurity, AnExpiredCertificateIsRefused) {
    // Fast DDS validates its own identity when the participant is created; the same PKI's
    // valid worker identity is the control.
    EXPECT_NO_THROW(Participant{secured("a", "worker")});
    try {
        Participant old(secured("a", "old_worker"));
        FAIL() << "a participant with an expired certificate was created";
    } catch (const DdsError& e) {
        EXPECT_NE(std::string(e.what()).find("old_worker"), std::string::npos) << e.what();
    }
}

TEST_F(DdsSecurity, WithoutSecurityTheSameRogueInjects) {
    Participant sample_db(plain("sample_db"));
    Participant rogue(plain("rogue"));
    std::atomic<int> forged{0};
    auto sub = sample_db.reader<v1::TaskResultPubSubType>(
        topics::kTaskResult, TopicQos::kReliable, [&](const v1::TaskResult& r) {
            if (r.task_id() == "forged") ++forged;
        });
    auto w = rogue.writer<v1::TaskResultPubSubType>(topics::kTaskResult, TopicQos::kReliable);
    EXPECT_TRUE(wait_until(
        [&] {
            w.write(result("forged"));
            return forged > 0;
        },
        30s));
}

}  // namespace
}  // namespace maptune::dds
