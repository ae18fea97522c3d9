#include "dds/participant.hpp"

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <set>
#include <thread>

namespace maptune::dds {

extern const char* const kLoopbackProfileXml;
extern const char* const kQosProfilesXml;

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::types::ReturnCode_t;

namespace {

// Each XML source is parsed once per process: parsing it again fails on duplicate ids.
// The topic QoS profiles (configs/dds/qos.xml) are loaded with the first of them.
bool load_profiles_once(const std::string& file) {
    static std::mutex mutex;
    static std::set<std::string> loaded;
    std::lock_guard<std::mutex> lock(mutex);
    if (loaded.count(file)) return true;
    auto* factory = fdds::DomainParticipantFactory::get_instance();
    static const bool qos_loaded =
        factory->load_XML_profiles_string(kQosProfilesXml, std::strlen(kQosProfilesXml)) == ReturnCode_t::RETCODE_OK;
    if (!qos_loaded) return false;
    const ReturnCode_t rc =
        file.empty() ? factory->load_XML_profiles_string(kLoopbackProfileXml,
                                                          std::strlen(kLoopbackProfileXml))
                     : factory->load_XML_profiles_file(file);
    if (rc != ReturnCode_t::RETCODE_OK) return false;
    loaded.insert(file);
    return true;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> security_properties(const ParticipantOptions& options) {
    if (options.security_dir.empty()) return {};
    namespace fs = std::filesystem;
    const fs::path dir = fs::absolute(options.security_dir);
    if (options.identity.empty()) {
        throw DdsError("DDS security directory " + dir.string() + " given without an identity");
    }
    const fs::path id = dir / options.identity;
    auto file = [&](const fs::path& p) {
        std::error_code ec;
        if (!fs::is_regular_file(p, ec)) {
            throw DdsError("DDS security: " + p.string() + " is missing (identity '" + options.identity +
                           "'; make one with scripts/make-pki.sh " + dir.string() + " --add " +
                           options.identity + " --role ROLE)");
        }
        return "file://" + p.string();
    };
    const std::string auth = "dds.sec.auth.builtin.PKI-DH.";
    const std::string access = "dds.sec.access.builtin.Access-Permissions.";
    return {
        {"dds.sec.auth.plugin", "builtin.PKI-DH"},
        {auth + "identity_ca", file(dir / "ca.pem")},
        {auth + "identity_certificate", file(id / "cert.pem")},
        {auth + "private_key", file(id / "key.pem")},
        {"dds.sec.access.plugin", "builtin.Access-Permissions"},
        {access + "permissions_ca", file(dir / "ca.pem")},
        {access + "governance", file(dir / "governance.p7s")},
        {access + "permissions", file(id / "permissions.p7s")},
        {"dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC"},
    };
}

std::string qos_profile(TopicQos qos, bool writer) {
    const char* base = qos == TopicQos::kReliable ? "maptune_reliable"
                       : qos == TopicQos::kLatched ? "maptune_latched"
                                                   : "maptune_best_effort";
    return std::string(base) + (writer ? "_writer" : "_reader");
}

fdds::DataWriterQos Participant::writer_qos(TopicQos qos) const {
    fdds::DataWriterQos q;
    if (publisher_->get_datawriter_qos_from_profile(qos_profile(qos, true), q) != ReturnCode_t::RETCODE_OK)
        throw DdsError("DDS QoS profile '" + qos_profile(qos, true) + "' is missing (configs/dds/qos.xml)");
    return q;
}

fdds::DataReaderQos Participant::reader_qos(TopicQos qos) const {
    fdds::DataReaderQos q;
    if (subscriber_->get_datareader_qos_from_profile(qos_profile(qos, false), q) != ReturnCode_t::RETCODE_OK)
        throw DdsError("DDS QoS profile '" + qos_profile(qos, false) + "' is missing (configs/dds/qos.xml)");
    return q;
}

Participant::Participant(const ParticipantOptions& options) : domain_id_(options.domain_id) {
    if (options.domain_id < 0 || options.domain_id > kMaxDomainId) {
        throw DdsError("DDS domain id " + std::to_string(options.domain_id) +
                       " is outside [0, " + std::to_string(kMaxDomainId) + "]");
    }
    auto* factory = fdds::DomainParticipantFactory::get_instance();
    if (!load_profiles_once(options.profiles_file)) {
        throw DdsError("cannot load DDS profiles from " +
                       (options.profiles_file.empty() ? std::string("the built-in loopback profile")
                                                      : options.profiles_file));
    }
    fdds::DomainParticipantQos qos;
    if (factory->get_participant_qos_from_profile(options.profile, qos) != ReturnCode_t::RETCODE_OK) {
        throw DdsError("DDS participant profile '" + options.profile + "' not found in " +
                       (options.profiles_file.empty() ? "the built-in profiles" : options.profiles_file));
    }
    qos.name(options.name);
    const auto security = security_properties(options);
    for (const auto& [key, value] : security) qos.properties().properties().emplace_back(key, value);
    if (!security.empty()) identity_ = options.identity;
    participant_ = factory->create_participant(static_cast<fdds::DomainId_t>(options.domain_id), qos);
    if (participant_ == nullptr) {
        // With security on, Fast DDS refuses an identity its CA did not sign, an expired
        // certificate or permissions that do not match it (its log says which).
        throw DdsError("cannot create a DDS participant on domain " + std::to_string(options.domain_id) +
                       (security.empty() ? std::string()
                                         : " with DDS-Security identity '" + options.identity + "' of " +
                                               options.security_dir +
                                               " (certificate not valid now, not signed by ca.pem, or "
                                               "permissions not matching it)"));
    }
    publisher_ = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    subscriber_ = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    if (publisher_ == nullptr || subscriber_ == nullptr) {
        throw DdsError("cannot create a DDS publisher/subscriber");
    }
}

Participant::~Participant() {
    if (participant_ != nullptr) {
        participant_->delete_contained_entities();
        fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
    }
}

fdds::Topic* Participant::topic_for(const std::string& topic, fdds::TopicDataType* type) {
    fdds::TypeSupport support(type);  // owns `type` from here on
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = topics_.find(topic); it != topics_.end()) return it->second;
    if (participant_->find_type(support.get_type_name()) == nullptr) {
        support.register_type(participant_);
    }
    auto* t = participant_->create_topic(topic, support.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    if (t == nullptr) throw DdsError("cannot create DDS topic '" + topic + "'" + denied_hint("use"));
    topics_[topic] = t;
    return t;
}

}  // namespace maptune::dds
