#pragma once
// Host-wide leases on DDS domain ids. maptune processes that pick a domain at random (embedded
// runs, tests) must not share one: on one domain an embedded run's requests reached a test's
// sample_db, which dispatched them to the run's worker (measured 2026-12-06, both on domain 91).
// A lease is an exclusive flock on <tmp>/maptune-dds-domains/<id>.lock held until the process
// exits; the kernel drops it even when the process is killed.

namespace maptune::dds {

// A domain in [lo, hi] that no other process holds, leased; throws std::runtime_error when
// every one is taken.
int lease_random_domain(int lo = 1, int hi = 200);

// Leases `domain` (a user's choice) if it is free or already this process's; false when
// another process holds it (the caller warns: that process's services would answer here).
bool lease_domain(int domain);

}  // namespace maptune::dds
