#include "scheduler/scheduler.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

namespace maptune::scheduler {

std::pair<std::string, std::string> pair_submaps(const std::string& pair_id) {
    const auto bar = pair_id.find('|');
    if (bar == std::string::npos) return {pair_id, pair_id};
    return {pair_id.substr(0, bar), pair_id.substr(bar + 1)};
}

std::vector<PlannedShard> plan_shards(const std::vector<std::string>& pair_ids, std::size_t shard_size,
                                      bool tiles_order) {
    const std::size_t n = pair_ids.size();
    std::vector<PlannedShard> shards;
    if (n == 0) return shards;
    // Submaps numbered in order of first appearance; components by union-find.
    std::map<std::string, std::size_t> number;
    std::vector<std::size_t> parent;
    std::vector<std::pair<std::size_t, std::size_t>> ends(n);
    auto root = [&](std::size_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    };
    for (std::size_t i = 0; i < n; ++i) {
        const auto [a, b] = pair_submaps(pair_ids[i]);
        for (const std::string* id : {&a, &b}) {
            if (number.emplace(*id, parent.size()).second) parent.push_back(parent.size());
        }
        ends[i] = {number.at(a), number.at(b)};
        parent[root(ends[i].first)] = root(ends[i].second);
    }
    // Components numbered in order of first appearance, and submaps within each.
    std::map<std::size_t, int> component;  // root -> component
    std::vector<std::size_t> local(parent.size());
    std::map<int, std::size_t> size_of;
    for (std::size_t s = 0; s < parent.size(); ++s) {
        const int c = component.emplace(root(s), static_cast<int>(component.size())).first->second;
        local[s] = size_of[c]++;
    }
    if (!tiles_order) {
        const std::size_t size = shard_size == 0 ? n : shard_size;
        for (std::size_t begin = 0; begin < n; begin += size) {
            PlannedShard shard;
            for (std::size_t k = begin; k < std::min(n, begin + size); ++k) shard.pairs.push_back(k);
            shard.component = component.at(root(ends[begin].first));
            shards.push_back(std::move(shard));
        }
        return shards;
    }
    const std::size_t block =
        shard_size == 0 ? std::numeric_limits<std::size_t>::max()
                        : static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(shard_size))));
    // (component, larger tile, smaller tile, pair)
    std::vector<std::tuple<int, std::size_t, std::size_t, std::size_t>> order;
    order.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t ta = local[ends[i].first] / block, tb = local[ends[i].second] / block;
        // Growing squares: all tiles of blocks 0..k before any tile touching block k + 1, so
        // the unstarted rest of a component needs submaps its first worker does not hold.
        order.emplace_back(component.at(root(ends[i].first)), std::max(ta, tb), std::min(ta, tb), i);
    }
    std::sort(order.begin(), order.end());
    // A component of at least `size` pairs is cut into equal shards; smaller ones are packed
    // together, consecutively, up to `size` pairs.
    const std::size_t size = shard_size == 0 ? n : shard_size;
    PlannedShard pack;
    auto flush = [&] {
        if (!pack.pairs.empty()) shards.push_back(std::move(pack));
        pack = {};
    };
    for (std::size_t begin = 0; begin < n;) {
        const int c = std::get<0>(order[begin]);
        std::size_t end = begin;
        while (end < n && std::get<0>(order[end]) == c) ++end;
        const std::size_t m = end - begin;
        if (m >= size) {
            flush();
            const std::size_t parts = (m + size - 1) / size;
            for (std::size_t p = 0; p < parts; ++p) {
                PlannedShard shard;
                shard.component = c;
                for (std::size_t k = begin + m * p / parts; k < begin + m * (p + 1) / parts; ++k) {
                    shard.pairs.push_back(std::get<3>(order[k]));
                }
                shards.push_back(std::move(shard));
            }
        } else {
            if (pack.pairs.size() + m > size) flush();
            if (pack.pairs.empty()) pack.component = c;
            for (std::size_t k = begin; k < end; ++k) pack.pairs.push_back(std::get<3>(order[k]));
        }
        begin = end;
    }
    flush();
    return shards;
}

namespace {

// A worker's submaps of one dataset (sample_db's proxy for its feature cache), or none.
const std::vector<char>* held_of(const std::map<std::string, std::vector<char>>& held, const std::string& dataset_id) {
    const auto it = held.find(dataset_id);
    return it == held.end() ? nullptr : &it->second;
}

bool holds(const std::vector<char>* held, int submap) {
    const auto i = static_cast<std::size_t>(submap);
    return held != nullptr && i < held->size() && (*held)[i];
}

}  // namespace

Scheduler::Scheduler(SchedulerOptions options) : options_(options) {
    if (options_.max_attempts < 1) options_.max_attempts = 1;
}

void Scheduler::heartbeat(const WorkerInfo& worker, double now, const std::vector<std::string>* held) {
    Worker& w = workers_[worker.id];
    w.info = worker;
    w.info.slots = std::max(1, worker.slots);
    w.last_seen = now;
    if (held == nullptr) return;
    const std::set<std::string> listed(held->begin(), held->end());
    std::vector<std::string> lost;
    for (const auto& task : w.tasks) {
        const Shard& shard = shards_.at(task);
        if (!listed.count(task) && now - shard.assigned_at > options_.delivery_grace_s) lost.push_back(task);
    }
    for (const auto& task : lost) {
        Shard& shard = shards_.at(task);
        --shard.attempts;  // never delivered: not an attempt
        requeue(shard);
    }
}

void Scheduler::remove_worker(const std::string& worker_id) {
    const auto it = workers_.find(worker_id);
    if (it == workers_.end()) return;
    for (const auto& task : std::set<std::string>(it->second.tasks)) requeue(shards_.at(task));
    forget(it->second);
    workers_.erase(it);
}

void Scheduler::requeue(Shard& shard) {
    if (auto w = workers_.find(shard.worker); w != workers_.end()) w->second.tasks.erase(shard.task_id);
    shard.worker.clear();
    // Re-assigned shards go first within their job (jobs themselves are served oldest first).
    jobs_.at(shard.job_key).queued.push_front(shard.task_id);
}

void Scheduler::hold(Worker& w, const Shard& shard, Job& job) {
    job.component_workers[shard.component].insert(w.info.id);
    SubmapIndex& index = submaps_[job.spec.dataset_id];
    std::vector<char>& held = w.held[job.spec.dataset_id];
    if (held.size() < index.holders.size()) held.resize(index.holders.size(), 0);
    for (const int id : shard.submaps) {
        if (held[static_cast<std::size_t>(id)]) continue;
        held[static_cast<std::size_t>(id)] = 1;
        ++index.holders[static_cast<std::size_t>(id)];
    }
}

void Scheduler::forget(Worker& w) {
    for (auto& [key, job] : jobs_) {
        for (auto& [component, ids] : job.component_workers) ids.erase(w.info.id);
    }
    for (const auto& [dataset_id, held] : w.held) {
        SubmapIndex& index = submaps_[dataset_id];
        for (std::size_t id = 0; id < held.size(); ++id) {
            if (held[id]) --index.holders[id];
        }
    }
    w.held.clear();
}

std::string Scheduler::pick_for(const Worker& w, double now) const {
    for (const auto& key : job_order_) {
        const Job& job = jobs_.at(key);
        if (job.queued.empty() || !compatible(w, job.spec, now)) continue;
        if (!options_.locality) return job.queued.front();
        const std::vector<char>* held = held_of(w.held, job.spec.dataset_id);
        const std::vector<int>& holders = submaps_.at(job.spec.dataset_id).holders;
        // Per component: queued work a newcomer could share; counted only when some shard
        // would make `w` join other workers (most picks end at a shard needing nothing new).
        std::map<int, std::size_t> queued_pairs;
        auto queued_in = [&](int component) {
            if (queued_pairs.empty()) {
                for (const auto& task : job.queued) {
                    const Shard& s = shards_.at(task);
                    queued_pairs[s.component] += s.pairs.size();
                }
            }
            return queued_pairs[component];
        };
        // Costs per pair of the shard (a small tail shard is not cheaper per unit of work).
        std::string member_best;           // best shard in a component `w` shares already
        std::size_t member_new = 0, member_pairs = 1;
        std::string best;
        bool best_shared = false;
        std::size_t best_new = 0, best_others = 0, best_pairs = 1, best_left = 0;
        for (const auto& task : job.queued) {
            const Shard& shard = shards_.at(task);
            std::size_t fresh = 0, others = 0;  // submaps new to w; of those, held by others
            for (const int id : shard.submaps) {
                if (holds(held, id)) continue;
                ++fresh;
                if (holders[static_cast<std::size_t>(id)] > 0) ++others;
            }
            bool shared = false;  // entering a component another worker is in
            bool member = false;
            if (fresh > 0) {
                if (const auto c = job.component_workers.find(shard.component); c != job.component_workers.end()) {
                    member = c->second.count(w.info.id) > 0;
                    shared = c->second.size() > (member ? 1u : 0u);
                }
            }
            const std::size_t pairs = std::max<std::size_t>(1, shard.pairs.size());
            if (shared && member && (member_best.empty() || fresh * member_pairs < member_new * pairs)) {
                member_best = task;
                member_new = fresh;
                member_pairs = pairs;
            }
            // Joining others: where the most work is left per worker already there.
            std::size_t left = 0;
            if (shared) {
                const auto& there = job.component_workers.at(shard.component);
                left = queued_in(shard.component) / there.size();
            }
            const auto a = fresh * best_pairs, b = best_new * pairs;
            const bool better = best.empty() || (shared != best_shared ? !shared
                                                 : a != b              ? a < b
                                                 : left != best_left   ? left > best_left
                                                                       : others * best_pairs < best_others * pairs);
            if (better) {
                best = task;
                best_shared = shared;
                best_new = fresh;
                best_others = others;
                best_pairs = pairs;
                best_left = left;
                if (fresh == 0) break;  // nothing to compute: cannot do better
            }
        }
        if (best_shared) {
            const auto& there = job.component_workers.at(shards_.at(best).component);
            const bool member = there.count(w.info.id) > 0;
            if (!member && !worth_joining(w, job, shards_.at(best).component, now)) {
                // Waiting is cheaper than computing others' submaps: keep to its own
                // components, else take work of a later job or stay free until the next round.
                if (!member_best.empty()) return member_best;
                continue;
            }
        }
        return best;
    }
    return {};
}

std::optional<std::pair<double, double>> Scheduler::cost_fit() const {
    const CostSums& c = cost_;
    if (c.n == 0) return std::nullopt;
    const double det = c.ff * c.pp - c.fp * c.fp;
    // Both unknowns need shards with and without new submaps (fresh not proportional to pairs).
    if (c.n >= 4 && c.ff > 0 && c.pp > 0 && det > 1e-6 * c.ff * c.pp) {
        const double a = (c.fd * c.pp - c.pd * c.fp) / det;  // seconds per new submap
        const double b = (c.pd * c.ff - c.fd * c.fp) / det;  // seconds per pair
        if (a > 0 && b > 0 && a / b >= 0.1 && a / b <= 1000) return std::make_pair(a, b);
    }
    // Otherwise only the scale: duration = b * (kDefaultFeaturePairs * fresh + pairs).
    const double r = kDefaultFeaturePairs;
    const double xx = r * r * c.ff + 2 * r * c.fp + c.pp, xd = r * c.fd + c.pd;
    if (!(xx > 0) || !(xd > 0)) return std::nullopt;
    return std::make_pair(r * xd / xx, xd / xx);
}

double Scheduler::feature_cost_in_pairs() const {
    const auto fit = cost_fit();
    return fit ? fit->first / fit->second : kDefaultFeaturePairs;
}

bool Scheduler::worth_joining(const Worker& w, const Job& job, int component, double now) const {
    // Predicted time, in pairs, for each component's workers to finish it: its queued and
    // running pairs plus the features of its queued submaps none of them holds, shared among
    // them. The job ends with the component that finishes last.
    struct Level {
        double pairs = 0;  // of queued shards
        double work = 0;   // left of running shards, in pairs
        std::set<int> unheld;
        std::vector<const Shard*> queued;
        std::set<int> held;  // submaps of queued shards its workers hold
    };
    const auto fit = cost_fit();
    const double r = feature_cost_in_pairs();
    std::map<int, Level> levels;
    const std::vector<char>* mine = held_of(w.held, job.spec.dataset_id);
    // Per component, its workers' submaps (looked up once, not per submap).
    std::map<int, std::vector<const std::vector<char>*>> members_held;
    for (const auto& [c, members] : job.component_workers) {
        for (const auto& m : members) {
            if (const auto it = workers_.find(m); it != workers_.end()) {
                members_held[c].push_back(held_of(it->second.held, job.spec.dataset_id));
            }
        }
    }
    for (const auto& id : job.shard_ids) {
        const Shard& shard = shards_.at(id);
        if (shard.done) continue;
        Level& level = levels[shard.component];
        if (!shard.worker.empty()) {
            // What is left of it: its expected time less the time it has run (without timings
            // yet, half of it).
            const double expected = r * static_cast<double>(shard.fresh) + static_cast<double>(shard.pairs.size());
            level.work += fit ? std::max(0.0, expected - (now - shard.assigned_at) / fit->second) : expected / 2;
            continue;
        }
        level.pairs += static_cast<double>(shard.pairs.size());
        level.queued.push_back(&shard);
        const auto& theirs = members_held[shard.component];
        for (const int sub : shard.submaps) {
            const bool held = std::any_of(theirs.begin(), theirs.end(), [&](const auto* h) { return holds(h, sub); });
            (held ? level.held : level.unheld).insert(sub);
        }
    }
    // None of its workers is alive: nobody else would finish it.
    bool attended = false;
    if (const auto members = job.component_workers.find(component); members != job.component_workers.end()) {
        for (const auto& m : members->second) {
            const auto it = workers_.find(m);
            attended = attended || (it != workers_.end() && compatible(it->second, job.spec, now));
        }
    }
    if (!attended) return true;
    auto holders = [&](int c) {
        const auto it = job.component_workers.find(c);
        return static_cast<double>(std::max<std::size_t>(1, it == job.component_workers.end() ? 0 : it->second.size()));
    };
    // Submaps a newcomer computes for its share of `pairs`, taking shards as pick_for does
    // (fewest new submaps per pair first): with a complete view about sqrt(share) of the
    // component's submaps, with subsequent pairs about share of them.
    struct Share {
        double features = 0;   // submaps the newcomer computes for its share, in pairs
        double duplicate = 0;  // the fraction of them others compute too
    };
    std::map<std::pair<int, int>, Share> share_memo;
    auto share_of = [&](int c, int extra) {
        const auto key = std::make_pair(c, extra);
        if (const auto it = share_memo.find(key); it != share_memo.end()) return it->second;
        const Level& l = levels.at(c);
        const double share = l.pairs / (holders(c) + extra);
        std::set<int> got;
        const std::size_t q = l.queued.size();
        std::vector<char> taken(q, 0);
        // Per queued shard, its submaps new to the newcomer and how many of those others hold;
        // both only fall as `got` grows, so the shards stay in an ordered set updated per new
        // submap instead of rescanning every shard per pick (that rescan was quadratic in the
        // queue: the coordinator's hot spot with many workers).
        std::vector<std::size_t> fresh(q, 0), others(q, 0), per(q, 1);
        std::map<int, std::vector<std::size_t>> containing;  // submap new to `w` -> shards with it
        for (std::size_t i = 0; i < q; ++i) {
            per[i] = std::max<std::size_t>(1, l.queued[i]->pairs.size());
            for (const int sub : l.queued[i]->submaps) {
                if (holds(mine, sub)) continue;
                ++fresh[i];
                others[i] += l.held.count(sub);
                containing[sub].push_back(i);
            }
        }
        // As pick_for: fewest new submaps per pair, then fewest held by the others, then first.
        auto before = [&](std::size_t a, std::size_t b) {
            const std::size_t x = fresh[a] * per[b], y = fresh[b] * per[a];
            if (x != y) return x < y;
            if (others[a] != others[b]) return others[a] < others[b];
            return a < b;
        };
        std::set<std::size_t, decltype(before)> order(before);
        for (std::size_t i = 0; i < q; ++i) order.insert(i);
        double pairs = 0;
        while (pairs < share && !order.empty()) {
            const std::size_t pick = *order.begin();
            order.erase(order.begin());
            taken[pick] = 1;
            pairs += static_cast<double>(l.queued[pick]->pairs.size());
            for (const int sub : l.queued[pick]->submaps) {
                if (holds(mine, sub) || !got.insert(sub).second) continue;
                for (const std::size_t j : containing[sub]) {
                    if (taken[j]) continue;
                    order.erase(j);
                    --fresh[j];
                    others[j] -= l.held.count(sub);
                    order.insert(j);
                }
            }
        }
        // Computed by others too: held by them already, or needed by the shards left to them.
        std::set<int> theirs = l.held;
        for (std::size_t i = 0; i < l.queued.size(); ++i) {
            if (!taken[i]) theirs.insert(l.queued[i]->submaps.begin(), l.queued[i]->submaps.end());
        }
        std::size_t twice = 0;
        for (const int sub : got) twice += theirs.count(sub);
        Share out;
        out.features = r * static_cast<double>(got.size());
        out.duplicate = got.empty() ? 0.0 : static_cast<double>(twice) / static_cast<double>(got.size());
        return share_memo[key] = out;
    };
    // The component's end with `extra` newcomers: its workers share the rest, each newcomer also
    // computes the submaps of its share.
    auto finish = [&](int c, int extra) {
        const Level& l = levels.at(c);
        const double alone = r * static_cast<double>(l.unheld.size()) + l.pairs + l.work;
        const double members = alone / (holders(c) + extra);
        return extra == 0 ? members : std::max(members, share_of(c, extra).features + l.pairs / (holders(c) + extra));
    };
    // Free slots of workers that can run the job, this one among them: the newcomers there are.
    int helpers = 0;
    for (const auto& [id, other] : workers_) {
        if (!compatible(other, job.spec, now)) continue;
        helpers += std::max(0, other.info.slots - static_cast<int>(other.tasks.size()));
    }
    // Water filling: each newcomer joins the component that would finish last, while that
    // shortens it.
    std::map<int, int> added;
    double before = 0;
    for (const auto& [c, l] : levels) before = std::max(before, finish(c, 0));
    for (int k = 0; k < helpers; ++k) {
        int worst = -1;
        double worst_t = -1;
        for (const auto& [c, l] : levels) {
            const double t = finish(c, added[c]);
            if (t > worst_t) {
                worst = c;
                worst_t = t;
            }
        }
        if (levels.at(worst).queued.empty() || finish(worst, added[worst] + 1) >= worst_t) break;
        ++added[worst];
    }
    double after = 0;
    for (const auto& [c, l] : levels) after = std::max(after, finish(c, added[c]));
    // Worth it when the evaluation ends sooner by more than a newcomer spends on features that
    // others compute too (duplicated work must buy at least as much wall time), and by at least
    // a pair's time (below what the estimate resolves; ties are no gain).
    double twice = 0;
    int newcomers = 0;
    for (const auto& [c, k] : added) {
        if (k == 0) continue;
        const Share sh = share_of(c, k);
        twice += k * sh.features * sh.duplicate;
        newcomers += k;
    }
    const double gain = before - after;
    if (added[component] > 0 && gain > std::max(1.0, twice / std::max(1, newcomers))) return true;
    // Or cheap: few of the submaps it would compute are computed by others too (a stretch of
    // subsequent pairs), so joining costs little even where it does not move the end.
    return share_of(component, 1).duplicate <= options_.join_duplication;
}

bool Scheduler::submit(const std::string& job_key, JobSpec spec, const std::string& requester,
                       double now) {
    if (auto it = jobs_.find(job_key); it != jobs_.end()) {
        // A re-sent request joins once: one answer per request id.
        auto& r = it->second.requesters;
        if (std::find(r.begin(), r.end(), requester) == r.end()) r.push_back(requester);
        return false;
    }
    Job job;
    job.requesters = {requester};
    job.started_at = now;
    job.pairs.resize(spec.pair_ids.size());
    for (std::size_t i = 0; i < spec.pair_ids.size(); ++i) job.pairs[i].pair_id = spec.pair_ids[i];
    SubmapIndex& index = submaps_[spec.dataset_id];
    for (auto& planned : plan_shards(spec.pair_ids, options_.shard_size, options_.locality)) {
        auto& pairs = planned.pairs;
        Shard shard;
        shard.component = planned.component;
        shard.task_id = options_.task_prefix + "t" + std::to_string(next_task_++);
        shard.job_key = job_key;
        for (const std::size_t i : pairs) {
            const auto [a, b] = pair_submaps(spec.pair_ids[i]);
            for (const std::string* id : {&a, &b}) {
                const auto [it, added] = index.ids.emplace(*id, static_cast<int>(index.holders.size()));
                if (added) index.holders.push_back(0);
                shard.submaps.push_back(it->second);
            }
        }
        std::sort(shard.submaps.begin(), shard.submaps.end());
        shard.submaps.erase(std::unique(shard.submaps.begin(), shard.submaps.end()), shard.submaps.end());
        shard.pairs = std::move(pairs);
        job.shard_ids.push_back(shard.task_id);
        job.queued.push_back(shard.task_id);
        shards_[shard.task_id] = std::move(shard);
    }
    job.remaining = job.shard_ids.size();
    job.spec = std::move(spec);
    const bool empty = job.remaining == 0;
    jobs_[job_key] = std::move(job);
    if (!empty) job_order_.push_back(job_key);
    if (empty) {
        Job& j = jobs_[job_key];
        completed_.push_back({job_key, j.spec, j.requesters, j.pairs, j.started_at, now});
        jobs_.erase(job_key);
    }
    return true;
}

std::vector<Assignment> Scheduler::schedule(double now) {
    for (auto& [id, w] : workers_) {
        if (now - w.last_seen <= options_.lease_s) continue;
        for (const auto& task : std::set<std::string>(w.tasks)) requeue(shards_.at(task));
    }
    for (auto it = workers_.begin(); it != workers_.end();) {
        // Forget long-silent workers; they re-register with their next heartbeat.
        if (now - it->second.last_seen > 3 * options_.lease_s) {
            forget(it->second);
            it = workers_.erase(it);
        } else {
            ++it;
        }
    }
    expire_unserved(now);
    std::vector<Assignment> out;
    // With every slot taken nothing can be assigned: skip the scan of the queue.
    if (queued_shards() == 0 || free_slots() == 0) return out;
    // One shard at a time to the least loaded worker that can take one (ties: id order), each
    // chosen for that worker's submaps.
    std::set<std::string> nothing_for;
    while (true) {
        Worker* w = nullptr;
        for (auto& [id, candidate] : workers_) {
            if (nothing_for.count(id) || now - candidate.last_seen > options_.lease_s) continue;
            if (candidate.info.slots - static_cast<int>(candidate.tasks.size()) <= 0) continue;
            if (w == nullptr || candidate.tasks.size() < w->tasks.size()) w = &candidate;
        }
        if (w == nullptr) break;
        const std::string task = pick_for(*w, now);
        if (task.empty()) {
            nothing_for.insert(w->info.id);
            continue;
        }
        Shard& shard = shards_.at(task);
        Job& job = jobs_.at(shard.job_key);
        job.queued.erase(std::find(job.queued.begin(), job.queued.end(), task));
        shard.worker = w->info.id;
        const std::vector<char>* held = held_of(w->held, job.spec.dataset_id);
        shard.fresh = static_cast<std::size_t>(
            std::count_if(shard.submaps.begin(), shard.submaps.end(), [&](int id) { return !holds(held, id); }));
        ++shard.attempts;
        shard.assigned_at = now;
        w->tasks.insert(task);
        hold(*w, shard, job);
        Assignment a;
        a.task_id = task;
        a.worker_id = w->info.id;
        a.job_key = shard.job_key;
        a.job = &job.spec;
        for (const std::size_t i : shard.pairs) a.pair_ids.push_back(job.spec.pair_ids[i]);
        a.attempt = shard.attempts;
        out.push_back(std::move(a));
    }
    return out;
}

std::size_t Scheduler::queued_shards() const {
    std::size_t n = 0;
    for (const auto& [key, job] : jobs_) n += job.queued.size();
    return n;
}

std::string code_revision(const std::string& matcher_version) {
    return matcher_version.substr(0, matcher_version.find('-'));
}

bool Scheduler::compatible(const Worker& w, const JobSpec& spec, double now) const {
    if (now - w.last_seen > options_.lease_s) return false;
    if (w.info.matcher_id != spec.matcher_id || w.info.space_hash != spec.space_hash) return false;
    if (spec.matcher_version.empty() || w.info.matcher_version == spec.matcher_version) return true;
    return w.info.takes_settings && !spec.matcher_settings.empty() &&
           code_revision(w.info.matcher_version) == code_revision(spec.matcher_version);
}

void Scheduler::expire_unserved(double now) {
    if (options_.unserved_timeout_s <= 0) return;
    std::vector<std::string> expired;
    for (auto& [key, job] : jobs_) {
        bool served = false;
        for (const auto& [id, w] : workers_) served = served || compatible(w, job.spec, now);
        if (served) {
            job.unserved_since.reset();
        } else if (!job.unserved_since) {
            job.unserved_since = now;
        } else if (now - *job.unserved_since > options_.unserved_timeout_s) {
            expired.push_back(key);
        }
    }
    for (const auto& key : expired) {
        Job& job = jobs_.at(key);
        job.worker_failures = true;
        job.failure = "no worker serves matcher '" + job.spec.matcher_id + "'" +
                      (job.spec.matcher_version.empty() ? "" : " version " + job.spec.matcher_version) +
                      " with design space " + job.spec.space_hash + " (waited " +
                      std::to_string(static_cast<long>(now - *job.unserved_since)) + " s)";
        std::vector<std::string> open;
        for (const auto& id : job.shard_ids) {
            if (!shards_.at(id).done) open.push_back(id);
        }
        for (const auto& id : open) {
            Shard& shard = shards_.at(id);
            for (const std::size_t i : shard.pairs) {
                job.pairs[i].matched = false;
                job.pairs[i].status = store::PairStatus::kFailed;
                job.pairs[i].reason = job.failure;
            }
            // The last one completes the job and erases it (and `job` with it).
            if (auto done = finish_shard(shard, now)) completed_.push_back(std::move(*done));
        }
    }
}

std::optional<CompletedJob> Scheduler::finish_shard(Shard& shard, double now) {
    shard.done = true;
    if (auto w = workers_.find(shard.worker); w != workers_.end()) w->second.tasks.erase(shard.task_id);
    Job& job = jobs_.at(shard.job_key);
    job.queued.erase(std::remove(job.queued.begin(), job.queued.end(), shard.task_id), job.queued.end());
    if (--job.remaining > 0) return std::nullopt;
    CompletedJob done{shard.job_key, std::move(job.spec), std::move(job.requesters),
                      std::move(job.pairs), job.started_at, now, job.worker_failures, job.failure};
    for (const auto& id : job.shard_ids) shards_.erase(id);
    jobs_.erase(done.job_key);
    job_order_.erase(std::remove(job_order_.begin(), job_order_.end(), done.job_key), job_order_.end());
    return done;
}

std::optional<CompletedJob> Scheduler::complete(const std::string& task_id,
                                                const std::string& worker_id,
                                                std::vector<store::PairRecord> results,
                                                double now) {
    const auto it = shards_.find(task_id);
    if (it == shards_.end() || it->second.done) return std::nullopt;
    Shard& shard = it->second;
    // A worker that lost its lease may still deliver, unless another worker holds it now.
    if (shard.worker != worker_id && !shard.worker.empty()) return std::nullopt;
    if (results.size() != shard.pairs.size()) {
        // A wrong-sized answer is a failed attempt, not a lost one: otherwise the shard would
        // stay assigned to a live worker forever.
        return fail(task_id, worker_id,
                    "returned " + std::to_string(results.size()) + " pair results for " +
                        std::to_string(shard.pairs.size()) + " pairs",
                    now);
    }
    if (auto w = workers_.find(worker_id); w != workers_.end()) w->second.last_seen = now;
    if (shard.worker == worker_id && now > shard.assigned_at) {
        const double f = static_cast<double>(shard.fresh), p = static_cast<double>(shard.pairs.size());
        const double d = now - shard.assigned_at;
        cost_.ff += f * f;
        cost_.fp += f * p;
        cost_.pp += p * p;
        cost_.fd += f * d;
        cost_.pd += p * d;
        ++cost_.n;
    }
    Job& job = jobs_.at(shard.job_key);
    for (std::size_t i = 0; i < results.size(); ++i) {
        store::PairRecord& slot = job.pairs[shard.pairs[i]];
        const std::string id = slot.pair_id;
        slot = std::move(results[i]);
        slot.pair_id = id;  // the order is the contract; ids from the worker are not trusted
    }
    return finish_shard(shard, now);  // also drops a re-queued shard delivered late from the queue
}

std::optional<CompletedJob> Scheduler::fail(const std::string& task_id,
                                            const std::string& worker_id,
                                            const std::string& reason, double now) {
    const auto it = shards_.find(task_id);
    if (it == shards_.end() || it->second.done || it->second.worker != worker_id) return std::nullopt;
    Shard& shard = it->second;
    shard.last_error = reason;
    if (shard.attempts < options_.max_attempts) {
        requeue(shard);
        return std::nullopt;
    }
    Job& job = jobs_.at(shard.job_key);
    job.worker_failures = true;
    job.failure = "a shard failed " + std::to_string(shard.attempts) + " times: " + reason;
    for (const std::size_t i : shard.pairs) {
        job.pairs[i].matched = false;
        job.pairs[i].status = store::PairStatus::kFailed;
        job.pairs[i].reason = "worker failed " + std::to_string(shard.attempts) + " times: " + reason;
    }
    return finish_shard(shard, now);
}

std::size_t Scheduler::running_shards() const {
    std::size_t n = 0;
    for (const auto& [id, w] : workers_) n += w.tasks.size();
    return n;
}

int Scheduler::free_slots() const {
    int n = 0;
    for (const auto& [id, w] : workers_) n += std::max(0, w.info.slots - static_cast<int>(w.tasks.size()));
    return n;
}

std::vector<CompletedJob> Scheduler::take_completed() {
    std::vector<CompletedJob> out;
    out.swap(completed_);
    return out;
}

}  // namespace maptune::scheduler
