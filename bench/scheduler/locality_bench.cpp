// Feature duplication and wall time of one evaluation spread over W workers, by simulating
// the real Scheduler (libs/scheduler) with workers whose feature caches are exact:
//   locality_bench --dataset DIR --view complete --workers 1,2,4,8,16
//   locality_bench --runs 40 --submaps 40 --view complete          (the moon preset's pairs)
//   locality_bench --runs 13 --submaps 15 --jitter 0.5 --repeats 20   (shard times vary ±50 %)
// A worker given a shard spends feature_s per submap of it that it has not computed before
// and pair_s per pair; it has one slot. The feature duplication factor is the feature
// computations summed over workers divided by the distinct submaps of the view. Prints one
// row per worker count and policy ("locality": the scheduler's default; "fifo": consecutive
// pairs oldest first, what sample_db did before).
#include <CLI/CLI.hpp>
#include <iomanip>
#include <iostream>
#include <map>
#include <queue>
#include <set>
#include <sstream>
#include <functional>
#include <random>
#include <tuple>

#include "dataset/dataset.hpp"
#include "scheduler/scheduler.hpp"

using namespace maptune;

namespace {

struct Outcome {
    double makespan = 0;
    std::size_t computations = 0;
    std::size_t distinct = 0;
    std::size_t warm_computations = 0;  // in the repeated evaluation (pair-stage change)
    double warm_makespan = 0;
};

struct SimWorker {
    std::set<std::string> cache;
    double busy_until = 0;
};

// Runs `jobs` evaluations one after the other (the second and later with the same per-submap
// parameters: only pair-stage parameters changed, so cached features are reused).
Outcome simulate(const std::vector<std::string>& pair_ids, int n_workers, bool locality,
                 std::size_t shard_size, double feature_s, double pair_s, int jobs, double jitter,
                 std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> noise(1.0 - jitter, 1.0 + jitter);
    scheduler::SchedulerOptions options;
    options.shard_size = shard_size;
    options.locality = locality;
    options.lease_s = 1e12;  // simulated time runs far beyond real leases
    options.unserved_timeout_s = 0;
    scheduler::Scheduler s(options);
    std::vector<SimWorker> workers(static_cast<std::size_t>(n_workers));
    auto id = [](std::size_t i) { return "w" + std::to_string(1000 + i); };
    std::set<std::string> distinct;
    for (const auto& p : pair_ids) {
        const auto [a, b] = scheduler::pair_submaps(p);
        distinct.insert(a);
        distinct.insert(b);
    }
    Outcome out;
    out.distinct = distinct.size();
    double now = 0;
    for (int j = 0; j < jobs; ++j) {
        const double start = now;
        std::size_t computed = 0;
        scheduler::JobSpec spec;
        spec.dataset_id = "ds";
        spec.view = "v";
        spec.matcher_id = "m";
        spec.space_hash = "s";
        spec.params = {{"n_TF", static_cast<double>(j)}};
        spec.pair_ids = pair_ids;
        s.submit("job" + std::to_string(j), spec, "bench", now);
        // (finish time, worker, task, pair ids)
        using Event = std::tuple<double, std::size_t, std::string, std::vector<std::string>>;
        std::priority_queue<Event, std::vector<Event>, std::greater<>> running;
        bool done = false;
        while (!done) {
            for (std::size_t i = 0; i < workers.size(); ++i) s.heartbeat({id(i), "m", "", "s", 1}, now);
            for (auto& a : s.schedule(now)) {
                const std::size_t w = std::stoul(a.worker_id.substr(1)) - 1000;
                double t = pair_s * static_cast<double>(a.pair_ids.size());
                for (const auto& p : a.pair_ids) {
                    const auto [x, y] = scheduler::pair_submaps(p);
                    for (const auto& sub : {x, y}) {
                        if (workers[w].cache.insert(sub).second) {
                            t += feature_s;
                            ++computed;
                        }
                    }
                }
                if (jitter > 0) t *= noise(rng);
                running.emplace(now + t, w, a.task_id, a.pair_ids);
            }
            if (running.empty()) break;
            auto [t, w, task, ids] = running.top();
            running.pop();
            now = t;
            std::vector<store::PairRecord> results(ids.size());
            for (std::size_t k = 0; k < ids.size(); ++k) results[k].pair_id = ids[k];
            done = s.complete(task, id(w), std::move(results), now).has_value();
        }
        if (j == 0) {
            out.makespan = now - start;
            out.computations = computed;
        } else {
            out.warm_makespan += now - start;
            out.warm_computations += computed;
        }
    }
    return out;
}

std::vector<int> parse_list(const std::string& text) {
    std::vector<int> out;
    std::stringstream in(text);
    for (std::string item; std::getline(in, item, ',');) out.push_back(std::stoi(item));
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Feature duplication and simulated wall time of one evaluation over W workers"};
    std::string dataset_dir, view = "complete", worker_list = "1,2,4,8,16", policy = "both";
    int runs = 0, submaps = 0;
    std::size_t shard_size = 8;
    double feature_s = 0.25, pair_s = 0.03, jitter = 0;
    int repeats = 1;
    app.add_option("--dataset", dataset_dir, "dataset directory (its view's pairs)");
    app.add_option("--runs", runs, "synthetic: runs (instead of --dataset)")->check(CLI::Range(1, 10000));
    app.add_option("--submaps", submaps, "synthetic: submaps per run")->check(CLI::Range(2, 10000));
    app.add_option("--view", view, "complete | subsequent")->check(CLI::IsMember({"complete", "subsequent"}));
    app.add_option("--workers", worker_list, "comma-separated worker counts (default 1,2,4,8,16)");
    app.add_option("--shard-size", shard_size, "pairs per shard (sample_db's --shard-size, default 8)");
    app.add_option("--feature-s", feature_s, "seconds per submap's features (default 0.25)")->check(CLI::Range(0.0, 1e4));
    app.add_option("--pair-s", pair_s, "seconds per pair stage (default 0.03)")->check(CLI::Range(0.0, 1e4));
    app.add_option("--jitter", jitter, "each shard's time times U(1 - J, 1 + J) (default 0: exact)")
        ->check(CLI::Range(0.0, 0.95));
    app.add_option("--repeats", repeats, "with --jitter: runs per row (mean of factor and wall)")
        ->check(CLI::Range(1, 1000));
    app.add_option("--policy", policy, "locality | fifo | both")->check(CLI::IsMember({"locality", "fifo", "both"}));
    CLI11_PARSE(app, argc, argv);

    std::vector<std::string> pair_ids;
    try {
        if (!dataset_dir.empty()) {
            const auto ds = dataset::Dataset::open(dataset_dir);
            for (const auto& p : ds.pairs(dataset::parse_view(view), dataset::Reference::gt)) {
                pair_ids.push_back(p.id_a + "|" + p.id_b);
            }
        } else if (runs > 0 && submaps > 0) {
            for (int r = 0; r < runs; ++r) {
                for (int a = 0; a < submaps; ++a) {
                    for (int b = a + 1; b < submaps; ++b) {
                        if (view == "subsequent" && b != a + 1) continue;
                        pair_ids.push_back("r" + std::to_string(r) + "/s" + std::to_string(a) + "|r" +
                                           std::to_string(r) + "/s" + std::to_string(b));
                    }
                }
            }
        } else {
            std::cerr << "locality_bench: give --dataset DIR or --runs N --submaps M\n";
            return 2;
        }
        std::vector<int> counts = parse_list(worker_list);
        std::cout << pair_ids.size() << " pairs; " << feature_s << " s features per submap, " << pair_s
                  << " s per pair, shard size " << shard_size << "\n\n";
        std::cout << "| policy | workers | feature computations | distinct submaps | duplication | "
                     "wall (simulated) | speed-up | pair-stage change: computations, wall |\n"
                     "|---|---|---|---|---|---|---|---|\n";
        for (const bool locality : {true, false}) {
            if ((locality && policy == "fifo") || (!locality && policy == "locality")) continue;
            double one = 0;
            for (const int w : counts) {
                if (w < 1) continue;
                Outcome o;
                for (int k = 0; k < repeats; ++k) {
                    const Outcome one_run = simulate(pair_ids, w, locality, shard_size, feature_s, pair_s, 2, jitter,
                                                     static_cast<std::uint64_t>(k + 1));
                    o.makespan += one_run.makespan / repeats;
                    o.computations += one_run.computations;
                    o.distinct = one_run.distinct;
                    o.warm_computations += one_run.warm_computations;
                    o.warm_makespan += one_run.warm_makespan / repeats;
                }
                o.computations /= static_cast<std::size_t>(repeats);
                o.warm_computations /= static_cast<std::size_t>(repeats);
                if (one == 0) one = o.makespan * w;  // first row is the reference when it is 1 worker
                std::cout << std::fixed << "| " << (locality ? "locality" : "fifo") << " | " << w << " | "
                          << o.computations << " | " << o.distinct << " | " << std::setprecision(3)
                          << static_cast<double>(o.computations) / static_cast<double>(o.distinct) << " | "
                          << std::setprecision(1) << o.makespan << " s | " << std::setprecision(2)
                          << (counts.front() == 1 ? one / o.makespan : 0.0) << "x | " << o.warm_computations
                          << ", " << std::setprecision(1) << o.warm_makespan << " s |\n";
            }
        }
    } catch (const std::exception& e) {
        std::cerr << "locality_bench: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
