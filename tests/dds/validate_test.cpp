// dds::check: the form of every incoming message (issue 14 item 3). A well-formed message of
// each kind passes; each kind of damage is refused naming the field.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dds/validate.hpp"

namespace maptune::dds {
namespace {

namespace v1 = msg::v1;

v1::NamedValue nv(const std::string& name, double value) {
    v1::NamedValue n;
    n.name(name);
    n.value(value);
    return n;
}

v1::PairResult pair() {
    v1::PairResult p;
    p.pair_id("run00/submap000|run00/submap001");
    p.matched(true);
    for (int i = 0; i < 16; ++i) p.t_a_b()[static_cast<std::size_t>(i)] = i % 5 == 0 ? 1.0 : 0.0;
    p.duration_s(0.5);
    p.status(v1::PAIR_OK);
    return p;
}

void expect_refused(const std::string& error, const std::string& fragment) {
    EXPECT_NE(error.find(fragment), std::string::npos) << "'" << error << "' lacks '" << fragment << "'";
}

TEST(MessageCheck, ObservationRequest) {
    v1::ObservationRequest r;
    r.request_id("e/1/1");
    r.view("complete");
    r.params({nv("r_N", 0.2), nv("n_C", 3)});
    r.matcher_settings({"icp_max_iterations=10"});
    EXPECT_EQ(check(r), "");
    auto bad = r;
    bad.params({nv("r_N", std::nan(""))});
    expect_refused(check(bad), "params: r_N is not a finite number");
    bad = r;
    bad.params(std::vector<v1::NamedValue>(MessageLimits::kParams + 1, nv("x", 1)));
    expect_refused(check(bad), "params: 257 entries (at most 256)");
    bad = r;
    bad.view(std::string(MessageLimits::kId + 1, 'v'));
    expect_refused(check(bad), "view: 1025 characters");
    bad = r;
    bad.matcher_settings({std::string(5000, 's')});
    expect_refused(check(bad), "matcher_settings: 5000 characters");
    bad = r;
    bad.params({nv(std::string(2000, 'n'), 1.0)});
    expect_refused(check(bad), "params: 2000 characters");
}

TEST(MessageCheck, RepliesAndResultsCarryWellFormedPairs) {
    v1::TaskResult t;
    t.task_id("x-t1");
    t.worker_id("w1");
    t.ok(true);
    t.pairs({pair(), pair()});
    EXPECT_EQ(check(t), "");
    auto bad = t;
    bad.pairs()[1].t_a_b()[3] = std::numeric_limits<double>::infinity();
    expect_refused(check(bad), "pairs.t_a_b: not a finite number");
    bad = t;
    bad.pairs()[0].duration_s(-1);
    expect_refused(check(bad), "pairs.duration_s: negative");
    bad = t;
    bad.pairs()[0].status(static_cast<v1::PairStatus>(7));
    expect_refused(check(bad), "pairs.status: unknown value 7");
    bad = t;
    bad.error(std::string(MessageLimits::kText + 1, 'e'));
    expect_refused(check(bad), "error: 65537 characters");

    v1::ObservationReply r;
    r.request_id("e/1/1");
    r.ok(true);
    r.params({nv("r_N", 0.2)});
    r.pairs({pair()});
    r.wall_seconds(1.5);
    EXPECT_EQ(check(r), "");
    auto bad_reply = r;
    bad_reply.wall_seconds(std::nan(""));
    expect_refused(check(bad_reply), "wall_seconds: not a finite number");
    bad_reply = r;
    bad_reply.pairs()[0].pair_id(std::string(4096, 'p'));
    expect_refused(check(bad_reply), "pairs.pair_id: 4096 characters");
}

TEST(MessageCheck, TasksStatusesAndFiles) {
    v1::EvaluationTask task;
    task.task_id("x-t1");
    task.worker_id("w1");
    task.params({nv("r_N", 0.2)});
    task.pair_ids({"a|b"});
    EXPECT_EQ(check(task), "");
    auto bad_task = task;
    bad_task.pair_ids({});
    expect_refused(check(bad_task), "pair_ids: empty");
    bad_task = task;
    bad_task.params({nv("t_K", -std::numeric_limits<double>::infinity())});
    expect_refused(check(bad_task), "params: t_K is not a finite number");

    v1::WorkerStatus s;
    s.worker_id("w1");
    s.slots(2);
    s.busy(1);
    s.tasks({"x-t1"});
    EXPECT_EQ(check(s), "");
    auto bad_status = s;
    bad_status.slots(0);
    expect_refused(check(bad_status), "slots: 0 (1..4096)");
    bad_status.slots(4000000000u);
    expect_refused(check(bad_status), "slots: 4000000000");
    bad_status = s;
    bad_status.busy(3);
    expect_refused(check(bad_status), "busy: 3 of 2 slots");
    bad_status = s;
    bad_status.worker_id("");
    expect_refused(check(bad_status), "worker_id: empty");

    v1::FileChunk c;
    c.request_id("c/1");
    c.index(0);
    c.count(2);
    c.data({1, 2, 3});
    EXPECT_EQ(check(c), "");
    auto bad_chunk = c;
    bad_chunk.index(2);
    expect_refused(check(bad_chunk), "index: 2 of 2");
    bad_chunk = c;
    bad_chunk.count(4000000000u);  // would allocate 4e9 chunk slots
    expect_refused(check(bad_chunk), "count: 4000000000");
    bad_chunk.count(0);
    expect_refused(check(bad_chunk), "count: 0");

    v1::FileRequest f;
    f.request_id("c/1");
    f.dataset_id("abc");
    f.path("run00/submap000/cloud.pcd");
    EXPECT_EQ(check(f), "");
    f.path(std::string(3000, '/'));
    expect_refused(check(f), "path: 3000 characters");

    v1::DatasetAnnouncement a;
    a.dataset_id("abc");
    v1::DatasetFile file;
    file.path("manifest.yaml");
    file.hash("0123");
    a.files({file});
    EXPECT_EQ(check(a), "");
    a.dataset_id("");
    expect_refused(check(a), "dataset_id: empty");
}

TEST(MessageCheck, WhatWatchReads) {
    v1::BestSoFar b;
    b.experiment_id("demo");
    b.best_p(0.8);
    b.best_params({nv("r_N", 0.2)});
    EXPECT_EQ(check(b), "");
    b.best_p(std::nan(""));
    expect_refused(check(b), "best_p: not a finite number");
    v1::OptimizerStatus s;
    s.experiment_id("demo");
    s.state("finished");
    EXPECT_EQ(check(s), "");
    s.gp_hyperparameters({nv("length_r_N", std::nan(""))});
    expect_refused(check(s), "gp_hyperparameters: length_r_N is not a finite number");
}

}  // namespace
}  // namespace maptune::dds
