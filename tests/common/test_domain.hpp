#pragma once
// DDS domains for tests that run side by side (ctest -j2) and beside embedded runs: a random
// domain in 1..200 that no other maptune process holds (dds/domain_lease.hpp). Two tests on
// one domain talk to each other's services (a fake worker "w1" of one test heartbeating to
// another test's sample_db) — a rare, real source of flaky failures.

#include "dds/domain_lease.hpp"

namespace maptune::test {

inline int reserve_domain() { return dds::lease_random_domain(1, 200); }  // below 232: room for participant ids

}  // namespace maptune::test
