#pragma once
// DDS options shared by every service executable and maptune command.

#include <CLI/CLI.hpp>
#include <string>

#include "dds/participant.hpp"

namespace maptune::services {

// --dds-security DIR (scripts/make-pki.sh) and, where one process has one identity,
// --dds-identity NAME.
inline void add_dds_security_options(CLI::App& app, std::string& dir, std::string* identity) {
    app.add_option("--dds-security", dir,
                   "DDS-Security: authenticate, check permissions and encrypt with the PKI in DIR "
                   "(scripts/make-pki.sh; default: off)")
        ->envname("MAPTUNE_DDS_SECURITY");
    if (identity != nullptr) {
        app.add_option("--dds-identity", *identity,
                       "DDS-Security identity in that directory (default: the service's role, '" +
                           *identity + "')")
            ->envname("MAPTUNE_DDS_IDENTITY");
    }
}

// `role` names the service's DDS-Security identity unless --dds-identity says otherwise.
inline void add_dds_options(CLI::App& app, dds::ParticipantOptions& o, const std::string& role) {
    o.identity = role;
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
    add_dds_security_options(app, o.security_dir, &o.identity);
}

}  // namespace maptune::services
