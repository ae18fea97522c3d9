#include "dds/participant.hpp"

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/topic/ContentFilteredTopic.hpp>
#include <fastdds/dds/topic/IContentFilterFactory.hpp>
#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>

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

namespace {

// Content filter "the type's `member`-th leading string member equals %0" (expression: the
// member's 0-based index). It reads only those strings of the CDR payload, so a writer can
// afford to evaluate it for every reader of every sample. (Fast DDS's DDS-SQL filter needs the
// types' TypeObjects, and evaluating it through DynamicData made task dispatch 2-3x slower
// than sending every task to every worker.)
constexpr const char* kLeadingStringFilter = "MAPTUNE_LEADING_STRING";

// Fast DDS's filter interfaces have no virtual destructor; these classes are final and only
// ever deleted as themselves.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnon-virtual-dtor"
class LeadingStringFilter final : public fdds::IContentFilter {
public:
    LeadingStringFilter(int member, std::string value) : member_(member), value_(std::move(value)) {}
    void set_value(std::string value) { value_ = std::move(value); }

    bool evaluate(const SerializedPayload& payload, const FilterSampleInfo&, const GUID_t&) const override {
        try {
            eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(payload.data), payload.length);
            eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
            cdr.read_encapsulation();
            std::string s;
            for (int i = 0; i <= member_; ++i) cdr >> s;
            return s == value_;
        } catch (const std::exception&) {
            return true;  // unreadable here: let the reader's own checks refuse it
        }
    }

private:
    int member_;
    std::string value_;
};

class LeadingStringFilterFactory final : public fdds::IContentFilterFactory {
public:
    ReturnCode_t create_content_filter(const char*, const char*, const fdds::TopicDataType*, const char* expression,
                                       const ParameterSeq& parameters, fdds::IContentFilter*& filter) override {
        if (parameters.length() != 1 || parameters[0] == nullptr) return ReturnCode_t::RETCODE_BAD_PARAMETER;
        if (expression == nullptr) {  // new parameters for the existing filter
            if (filter == nullptr) return ReturnCode_t::RETCODE_BAD_PARAMETER;
            static_cast<LeadingStringFilter*>(filter)->set_value(parameters[0]);
            return ReturnCode_t::RETCODE_OK;
        }
        char* end = nullptr;
        const long member = std::strtol(expression, &end, 10);
        if (end == expression || *end != '\0' || member < 0 || member > 16) return ReturnCode_t::RETCODE_BAD_PARAMETER;
        delete static_cast<LeadingStringFilter*>(filter);
        filter = new LeadingStringFilter(static_cast<int>(member), parameters[0]);
        return ReturnCode_t::RETCODE_OK;
    }
    ReturnCode_t delete_content_filter(const char*, fdds::IContentFilter* filter) override {
        delete static_cast<LeadingStringFilter*>(filter);
        return ReturnCode_t::RETCODE_OK;
    }
};

#pragma GCC diagnostic pop

// Outlives every participant (registered with each).
LeadingStringFilterFactory& leading_string_filters() {
    static LeadingStringFilterFactory factory;
    return factory;
}

}  // namespace

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
    q.writer_resource_limits().reader_filters_allocation =
        eprosima::fastrtps::ResourceLimitedContainerConfig(0, kMaxReaderFilters, 1);
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
    participant_->register_content_filter_factory(kLeadingStringFilter, &leading_string_filters());
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

fdds::TopicDescription* Participant::filtered_topic(fdds::Topic* topic, int member, const std::string& value) {
    const std::string name = topic->get_name() + "|" + std::to_string(member) + "=" + value;
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = filtered_topics_.find(name); it != filtered_topics_.end()) return it->second;
    fdds::TopicDescription* d = participant_->create_contentfilteredtopic(name, topic, std::to_string(member),
                                                                          {value}, kLeadingStringFilter);
    if (d == nullptr) d = topic;  // unfiltered: the callback still checks
    filtered_topics_[name] = d;
    return d;
}

}  // namespace maptune::dds
