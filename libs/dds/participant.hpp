#pragma once
// A DDS participant created from a profile that keeps traffic on loopback unless the user
// names another profile, plus typed writers and readers. This is the only layer that
// includes Fast DDS headers; services use it and the generated types in "maptune.h".

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace maptune::dds {

class DdsError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

inline constexpr int kMaxDomainId = 232;  // larger ids overflow the RTPS port range

struct ParticipantOptions {
    int domain_id = 0;           // 0..232
    std::string profiles_file;   // Fast DDS XML; empty: the built-in loopback profile
    std::string profile = "maptune_loopback";  // participant profile in that XML
    std::string name = "maptune";
    // DDS-Security (scripts/make-pki.sh): empty = off. With a directory, the participant
    // authenticates as `identity` (a subdirectory holding cert.pem, key.pem, permissions.p7s)
    // and the directory's ca.pem and governance.p7s decide whom it talks to and what it may
    // publish; services default `identity` to their role.
    std::string security_dir;
    std::string identity;
};

// The Fast DDS properties that switch the builtin security plugins on for `options`; throws
// DdsError naming the first missing file. Empty when security is off.
std::vector<std::pair<std::string, std::string>> security_properties(const ParticipantOptions& options);

// Readers with a content filter a writer evaluates for them (beyond that, it sends them every
// sample and they filter on receipt). Fast DDS's default is 32.
inline constexpr int kMaxReaderFilters = 1024;

// Delivery semantics of a topic: each is a pair of writer/reader profiles in
// configs/dds/qos.xml (compiled in; the wire contract in docs/plugin-matcher.md).
enum class TopicQos {
    kReliable,  // reliable, volatile, keep last 1000: requests, tasks, results
    kLatched,   // reliable, transient-local, keep last 1 per key: late joiners get the latest
    kBestEffort,  // heartbeats
};

// "maptune_reliable_writer", "maptune_latched_reader", ...
std::string qos_profile(TopicQos qos, bool writer);

template <class T>
class Writer {
public:
    explicit Writer(eprosima::fastdds::dds::DataWriter* w = nullptr) : writer_(w) {}
    // False when the sample could not be queued (e.g. history full past its blocking time).
    bool write(const T& sample) const {
        return writer_ != nullptr && writer_->write(const_cast<T*>(&sample));
    }
    int matched() const {
        eprosima::fastdds::dds::PublicationMatchedStatus s;
        if (writer_ == nullptr || writer_->get_publication_matched_status(s) != ReturnOk()) {
            return 0;
        }
        return s.current_count;
    }
    // Blocks until at least `n` readers matched or the timeout passes.
    bool wait_for_readers(int n, std::chrono::milliseconds timeout) const;

private:
    static eprosima::fastrtps::types::ReturnCode_t ReturnOk() {
        return eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
    }
    eprosima::fastdds::dds::DataWriter* writer_;
};

// Whether a reader's callback may still run: closed by its Subscription.
struct ReaderGate {
    std::mutex mutex;  // held while the callback runs
    bool open = true;
};

// Calls `on_sample` on a Fast DDS thread for every valid sample taken, while its gate is open.
template <class T>
class ReaderListener : public eprosima::fastdds::dds::DataReaderListener {
public:
    ReaderListener(std::function<void(const T&)> on_sample, std::shared_ptr<ReaderGate> gate)
        : on_sample_(std::move(on_sample)), gate_(std::move(gate)) {}
    void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
        T sample;
        eprosima::fastdds::dds::SampleInfo info;
        while (reader->take_next_sample(&sample, &info) ==
               eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
            std::lock_guard<std::mutex> lock(gate_->mutex);
            if (!gate_->open) return;
            if (info.valid_data) on_sample_(sample);
        }
    }

private:
    std::function<void(const T&)> on_sample_;
    std::shared_ptr<ReaderGate> gate_;
};

// Owns a reader's callback: once it is destroyed (or reset), the callback has returned and
// never runs again. A service keeps its subscriptions as its last members, so they close
// before anything the callbacks touch is destroyed — even though the Participant, which
// owns the readers, outlives the service.
class Subscription {
public:
    Subscription() = default;
    explicit Subscription(std::shared_ptr<ReaderGate> gate) : gate_(std::move(gate)) {}
    Subscription(Subscription&&) noexcept = default;
    Subscription& operator=(Subscription&& other) noexcept {
        if (this != &other) {
            reset();
            gate_ = std::move(other.gate_);
        }
        return *this;
    }
    Subscription(const Subscription&) = delete;
    Subscription& operator=(const Subscription&) = delete;
    ~Subscription() { reset(); }
    void reset() {
        if (!gate_) return;
        std::lock_guard<std::mutex> lock(gate_->mutex);  // waits for a running callback
        gate_->open = false;
        gate_.reset();
    }

private:
    std::shared_ptr<ReaderGate> gate_;
};

class Participant {
public:
    // Throws DdsError when the domain id is out of range, the XML does not load or the
    // profile does not exist (never falls back to Fast DDS's every-interface default).
    explicit Participant(const ParticipantOptions& options);
    ~Participant();
    Participant(const Participant&) = delete;
    Participant& operator=(const Participant&) = delete;

    int domain_id() const { return domain_id_; }

    template <class PubSubType>
    Writer<typename PubSubType::type> writer(const std::string& topic, TopicQos qos) {
        auto* t = topic_for(topic, new PubSubType());
        auto* w = publisher_->create_datawriter(t, writer_qos(qos));
        if (w == nullptr) throw DdsError("cannot create a writer on topic '" + topic + "'" + denied_hint("publish"));
        return Writer<typename PubSubType::type>(w);
    }

    // The callback runs on a Fast DDS thread until the returned Subscription is destroyed.
    template <class PubSubType>
    [[nodiscard]] Subscription reader(const std::string& topic, TopicQos qos,
                                      std::function<void(const typename PubSubType::type&)> on_sample) {
        return reader_on<typename PubSubType::type>(topic_for(topic, new PubSubType()), qos, std::move(on_sample));
    }

    // A reader that gets only the samples whose `member`-th leading string member (0-based,
    // in IDL order; EvaluationTask's worker_id is 1) equals `value`: a content-filtered topic.
    // The filter is announced in discovery, so a maptune writer evaluates it for each reader
    // (up to kMaxReaderFilters per writer) and sends each sample only to the readers that
    // want it instead of to all of them: the task topic's fan-out to every worker. Foreign
    // writers send everything and the reader filters; callbacks check the field anyway.
    template <class PubSubType>
    [[nodiscard]] Subscription reader_where(const std::string& topic, TopicQos qos, int member,
                                            const std::string& value,
                                            std::function<void(const typename PubSubType::type&)> on_sample) {
        return reader_on<typename PubSubType::type>(filtered_topic(topic_for(topic, new PubSubType()), member, value),
                                                    qos, std::move(on_sample));
    }

    // The QoS of qos_profile(qos, …); throws DdsError when the profile is missing.
    eprosima::fastdds::dds::DataWriterQos writer_qos(TopicQos qos) const;
    eprosima::fastdds::dds::DataReaderQos reader_qos(TopicQos qos) const;

private:
    template <class T>
    Subscription reader_on(eprosima::fastdds::dds::TopicDescription* topic, TopicQos qos,
                           std::function<void(const T&)> on_sample) {
        const auto rq = reader_qos(qos);
        auto gate = std::make_shared<ReaderGate>();
        auto listener = std::make_unique<ReaderListener<T>>(std::move(on_sample), gate);
        auto* r = subscriber_->create_datareader(topic, rq, listener.get());
        if (r == nullptr) {
            throw DdsError("cannot create a reader on topic '" + topic->get_name() + "'" + denied_hint("read"));
        }
        std::lock_guard<std::mutex> lock(mutex_);
        listeners_.push_back(std::move(listener));
        return Subscription(std::move(gate));
    }

    // Registers the type on first use (taking ownership of `type`) and returns the topic.
    eprosima::fastdds::dds::Topic* topic_for(const std::string& topic,
                                            eprosima::fastdds::dds::TopicDataType* type);

    // The content-filtered view of `topic` where leading string `member` = `value` (made once
    // per pair); `topic` itself when no filter can be made.
    eprosima::fastdds::dds::TopicDescription* filtered_topic(eprosima::fastdds::dds::Topic* topic, int member,
                                                            const std::string& value);

    // With DDS-Security, why an entity may be refused: the identity's permissions.
    std::string denied_hint(const std::string& verb) const {
        return identity_.empty() ? std::string()
                                 : " (DDS-Security: identity '" + identity_ + "' may not " + verb + " it)";
    }

    int domain_id_ = 0;
    std::string identity_;  // set when DDS-Security is on
    eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
    eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
    eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
    std::mutex mutex_;
    std::map<std::string, eprosima::fastdds::dds::Topic*> topics_;
    std::map<std::string, eprosima::fastdds::dds::TopicDescription*> filtered_topics_;
    std::vector<std::unique_ptr<eprosima::fastdds::dds::DataReaderListener>> listeners_;
};

template <class T>
bool Writer<T>::wait_for_readers(int n, std::chrono::milliseconds timeout) const {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (matched() < n) {
        if (std::chrono::steady_clock::now() >= deadline) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
}

}  // namespace maptune::dds
