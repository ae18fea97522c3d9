#include "dds/participant.hpp"

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>

#include <algorithm>
#include <cstring>
#include <mutex>
#include <set>
#include <thread>

namespace maptune::dds {

extern const char* const kLoopbackProfileXml;

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::types::ReturnCode_t;

namespace {

// Keyed topics hold one instance per worker, dataset or experiment: allow many (the
// default is 10), each with `depth` samples.
template <class Qos>
void unlimited_instances(Qos& q) {
    const int32_t depth = q.history().depth;
    q.resource_limits().max_instances = 4096;
    q.resource_limits().max_samples_per_instance = depth;
    q.resource_limits().max_samples = std::max<int32_t>(depth, 4096);
}

// Each XML source is parsed once per process: parsing it again fails on duplicate ids.
bool load_profiles_once(const std::string& file) {
    static std::mutex mutex;
    static std::set<std::string> loaded;
    std::lock_guard<std::mutex> lock(mutex);
    if (loaded.count(file)) return true;
    auto* factory = fdds::DomainParticipantFactory::get_instance();
    const ReturnCode_t rc =
        file.empty() ? factory->load_XML_profiles_string(kLoopbackProfileXml,
                                                          std::strlen(kLoopbackProfileXml))
                     : factory->load_XML_profiles_file(file);
    if (rc != ReturnCode_t::RETCODE_OK) return false;
    loaded.insert(file);
    return true;
}

}  // namespace

void apply_qos(TopicQos qos, fdds::DataWriterQos& w) {
    switch (qos) {
        case TopicQos::kReliable:
            w.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
            w.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
            w.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
            w.history().depth = 1000;
            break;
        case TopicQos::kLatched:
            w.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
            w.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
            w.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
            w.history().depth = 1;
            break;
        case TopicQos::kBestEffort:
            w.reliability().kind = fdds::BEST_EFFORT_RELIABILITY_QOS;
            w.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
            w.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
            w.history().depth = 1;
            break;
    }
    unlimited_instances(w);
}

void apply_qos(TopicQos qos, fdds::DataReaderQos& r) {
    switch (qos) {
        case TopicQos::kReliable:
            r.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
            r.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
            r.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
            r.history().depth = 1000;
            break;
        case TopicQos::kLatched:
            r.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
            r.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
            r.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
            r.history().depth = 1;
            break;
        case TopicQos::kBestEffort:
            r.reliability().kind = fdds::BEST_EFFORT_RELIABILITY_QOS;
            r.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
            r.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
            r.history().depth = 1;
            break;
    }
    unlimited_instances(r);
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
    participant_ = factory->create_participant(static_cast<fdds::DomainId_t>(options.domain_id), qos);
    if (participant_ == nullptr) {
        throw DdsError("cannot create a DDS participant on domain " +
                       std::to_string(options.domain_id));
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
    if (t == nullptr) throw DdsError("cannot create DDS topic '" + topic + "'");
    topics_[topic] = t;
    return t;
}

}  // namespace maptune::dds
