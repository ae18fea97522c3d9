#pragma once
// DDS options shared by every service executable and maptune command.

#include <CLI/CLI.hpp>
#include <string>

#include "dds/participant.hpp"

namespace maptune::services {

inline void add_dds_options(CLI::App& app, dds::ParticipantOptions& o) {
    app.add_option("--domain", o.domain_id, "DDS domain id, 0..232 (default: 0)")
        ->check(CLI::Range(0, dds::kMaxDomainId))
        ->envname("MAPTUNE_DOMAIN");
    app.add_option("--dds-profiles", o.profiles_file,
                   "Fast DDS XML profiles file (default: the built-in loopback-only profile; "
                   "configs/dds/network_udp.xml for real networks)")
        ->envname("MAPTUNE_DDS_PROFILES");
    app.add_option("--dds-profile", o.profile,
                   "participant profile in that file (default: maptune_loopback)")
        ->envname("MAPTUNE_DDS_PROFILE");
}

}  // namespace maptune::services
