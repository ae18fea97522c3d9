#pragma once
// A thread-safe in-memory LRU cache of shared immutable values, bounded by bytes and entries.
// Concurrent requests for the same key compute once and share the result. Used for per-submap
// features and for per-pair descriptor neighbour lists.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <future>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

namespace maptune::matcher {

struct CacheStats {
    std::uint64_t hits = 0;
    std::uint64_t misses = 0;  // computations started
    std::uint64_t evictions = 0;
    std::size_t bytes = 0;
    std::size_t entries = 0;
};

// T must provide `std::size_t bytes() const`.
template <typename T>
class LruCache {
  public:
    using Ptr = std::shared_ptr<const T>;
    LruCache(std::size_t max_bytes, std::size_t max_entries)
        : max_bytes_(max_bytes), max_entries_(max_entries) {}

    // The cached value, or compute() run outside the lock; the result is stored when
    // keep(value) holds. An exception from compute() reaches every waiter; nothing is stored.
    Ptr get_or_compute(const std::string& key, const std::function<Ptr()>& compute,
                       const std::function<bool(const T&)>& keep = {}) {
        std::promise<Ptr> promise;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            auto it = index_.find(key);
            if (it != index_.end()) {
                lru_.splice(lru_.begin(), lru_, it->second);
                ++stats_.hits;
                return it->second->value;
            }
            auto fl = in_flight_.find(key);
            if (fl != in_flight_.end()) {
                auto future = fl->second;
                ++stats_.hits;
                lock.unlock();
                return future.get();
            }
            ++stats_.misses;
            in_flight_.emplace(key, promise.get_future().share());
        }
        Ptr value;
        try {
            value = compute();
        } catch (...) {
            std::lock_guard<std::mutex> lock(mutex_);
            in_flight_.erase(key);
            promise.set_exception(std::current_exception());
            throw;
        }
        {
            std::lock_guard<std::mutex> lock(mutex_);
            in_flight_.erase(key);
            if (value && (!keep || keep(*value))) insert_locked(key, value);
        }
        promise.set_value(value);
        return value;
    }

    // No compute; counts a hit if present.
    Ptr find(const std::string& key) {
        std::lock_guard<std::mutex> lock(mutex_);
        auto it = index_.find(key);
        if (it == index_.end()) return nullptr;
        lru_.splice(lru_.begin(), lru_, it->second);
        ++stats_.hits;
        return it->second->value;
    }

    CacheStats stats() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return stats_;
    }

    void clear() {
        std::lock_guard<std::mutex> lock(mutex_);
        lru_.clear();
        index_.clear();
        stats_.bytes = 0;
        stats_.entries = 0;
    }

  private:
    struct Entry {
        std::string key;
        Ptr value;
        std::size_t bytes = 0;
    };

    void insert_locked(const std::string& key, Ptr value) {
        const std::size_t bytes = value->bytes() + key.size();
        lru_.push_front(Entry{key, std::move(value), bytes});
        index_[key] = lru_.begin();
        stats_.bytes += bytes;
        // Never evict the entry just inserted (front), or one big value could not be cached.
        while (lru_.size() > 1 && (stats_.bytes > max_bytes_ || lru_.size() > max_entries_)) {
            const Entry& victim = lru_.back();
            stats_.bytes -= victim.bytes;
            index_.erase(victim.key);
            lru_.pop_back();
            ++stats_.evictions;
        }
        stats_.entries = lru_.size();
    }

    std::size_t max_bytes_, max_entries_;
    mutable std::mutex mutex_;
    std::list<Entry> lru_;  // front = most recently used
    std::unordered_map<std::string, typename std::list<Entry>::iterator> index_;
    std::unordered_map<std::string, std::shared_future<Ptr>> in_flight_;
    CacheStats stats_;
};

}  // namespace maptune::matcher
