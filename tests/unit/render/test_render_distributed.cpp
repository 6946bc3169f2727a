// A render's passes shared among ranks (PassExchange.h), with the ranks simulated by threads of
// this process: rank 0's film, tallies and statistics are bitwise one renderer's, for 2 and 3
// ranks, with beams, guided and unguided photons and a dusty lens (every kind of job and hit).
// Runs in every build, with or without MPI (the CLI tests run the MPI transport itself).
#include <algorithm>
#include <atomic>
#include <barrier>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "RenderTestUtil.h"
#include "TestUtil.h"
#include "flare/render/PassExchange.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"

namespace flare {
namespace {

// R ranks in one process: a message to rank 0 waits in its sender's queue until rank 0 takes it
// (the sender goes on at once, as with MPI); an exchange of messages between every pair and a
// broadcast: a rank deposits its messages, all meet, each takes its own, all meet again (so that
// no rank's next message overwrites one not yet taken).
class ThreadRanks {
public:
    explicit ThreadRanks(int size) : size_(size), meet_(size) {}
    int size() const { return size_; }
    void sendToRoot(int rank, const std::vector<char>& mine) {
        std::lock_guard<std::mutex> lock(mutex_);
        queues_[rank].push_back(mine);
        arrived_.notify_all();
    }
    void receiveAtRoot(std::vector<std::vector<char>>& all) {
        all.assign(size_, {});
        std::unique_lock<std::mutex> lock(mutex_);
        for (int r = 1; r < size_; ++r) {
            arrived_.wait(lock, [&] { return !queues_[r].empty(); });
            all[r] = std::move(queues_[r].front());
            queues_[r].pop_front();
        }
    }
    void allToAll(int rank, const std::vector<std::vector<char>>& out, std::vector<std::vector<char>>& in) {
        mail_[rank] = out;
        meet_.arrive_and_wait();
        in.assign(size_, {});
        for (int r = 0; r < size_; ++r)
            if (r != rank) in[r] = mail_[r][rank];
        meet_.arrive_and_wait();
    }
    void broadcast(int rank, std::vector<int>& values) {
        if (rank == 0) values_ = values;
        meet_.arrive_and_wait();
        const std::vector<int> root = values_;
        meet_.arrive_and_wait();
        ASSERT_EQ(root.size(), values.size());
        values = root;
    }
    int broadcast(int rank, int value) {
        std::vector<int> values{value};
        broadcast(rank, values);
        return values[0];
    }
    long claim(int slot, long count) { return claims_[slot & 1].fetch_add(count); }
    void resetClaims(int slot) { claims_[slot & 1].store(0); }

private:
    int size_;
    std::vector<std::deque<std::vector<char>>> queues_ = std::vector<std::deque<std::vector<char>>>(size_);
    std::mutex mutex_;
    std::condition_variable arrived_;
    std::vector<std::vector<std::vector<char>>> mail_ = std::vector<std::vector<std::vector<char>>>(size_);
    std::vector<int> values_;
    std::barrier<> meet_;
    std::atomic<long> claims_[2] = {0, 0};
};

class ThreadRank final : public PassExchange {
public:
    ThreadRank(ThreadRanks& ranks, int rank) : ranks_(ranks), rank_(rank) {}
    int rank() const override { return rank_; }
    int size() const override { return ranks_.size(); }
    void sendToRoot(const std::vector<char>& mine) override { ranks_.sendToRoot(rank_, mine); }
    void receiveAtRoot(std::vector<std::vector<char>>& all) override { ranks_.receiveAtRoot(all); }
    void finishSends() override {}
    void allToAll(const std::vector<std::vector<char>>& out, std::vector<std::vector<char>>& in) override {
        ranks_.allToAll(rank_, out, in);
    }
    int broadcastFromRoot(int value) override { return ranks_.broadcast(rank_, value); }
    void broadcastFromRoot(std::vector<int>& values) override { ranks_.broadcast(rank_, values); }
    long claimJobs(int slot, long count) override { return ranks_.claim(slot, count); }
    void resetClaims(int slot) override { ranks_.resetClaims(slot); }

private:
    ThreadRanks& ranks_;
    int rank_;
};

Scene dustyScene() {
    return parseSceneText(R"({"lens": "double-gauss-50mm", "f_number": 4,
        "sensor": {"resolution": [192, 128]},
        "lights": [{"type": "directional", "field_deg": [11, 8], "angular_diameter_deg": 0.53}],
        "scattering": {"dust": [{"surface": 1, "coverage": 0.02}]},
        "render": {"diffraction": false}})",
                          "dusty.json", "");
}

bool sameBits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(RenderDistributed, RanksGiveBitwiseTheFilmTalliesAndStatisticsOfOneRenderer) {
    const Scene scene = dustyScene();
    const LensSystem lens = buildSceneLens(scene);
    RenderOptions options = test::sceneRenderOptions(scene, lens, RenderOptions::Mode::Guided);
    options.perGhostLayers = true;
    // (Five passes: the adaptive pass plan sizes passes 3 and 4 from the film, which rank 0 alone
    // holds; the others learn each pass's sizes a pass ahead.)
    constexpr int kPasses = 5;
    Renderer alone(lens, scene.lights, options);
    for (int p = 0; p < kPasses; ++p) alone.runPass();
    ASSERT_GT(alone.statistics().beams, 0);
    ASSERT_GT(alone.statistics().unguidedPhotons, 0);
    ASSERT_TRUE(alone.adaptivePassPlan());
    const auto plan = alone.passPlan();
    EXPECT_TRUE(plan[3].first != 1.0 || plan[3].second != options.batchesPerPass) << "the plan kept the nominal pass";

    // (Without a pass limit the other ranks trace a pass ahead that is never sent: the last.)
    for (const auto& [size, passLimit] : {std::pair{2, 0}, std::pair{3, 0}, std::pair{2, kPasses}}) {
        SCOPED_TRACE(std::to_string(size) + " ranks, pass limit " + std::to_string(passLimit));
        ThreadRanks ranks(size);
        std::vector<std::unique_ptr<Renderer>> renderers;
        std::vector<std::unique_ptr<ThreadRank>> views;
        for (int r = 0; r < size; ++r) {
            renderers.push_back(std::make_unique<Renderer>(lens, scene.lights, options));
            views.push_back(std::make_unique<ThreadRank>(ranks, r));
            renderers.back()->setExchange(views.back().get());
            renderers.back()->setPassLimit(passLimit);
        }
        std::vector<std::thread> threads;
        for (int r = 0; r < size; ++r)
            threads.emplace_back([&, r] {
                for (int p = 0; p < kPasses; ++p) renderers[r]->runPass();
            });
        for (std::thread& t : threads) t.join();

        const Renderer& root = *renderers[0];
        ASSERT_EQ(root.layerNames(), alone.layerNames());
        for (size_t l = 0; l < alone.layerNames().size(); ++l)
            EXPECT_TRUE(sameBits(root.layerXyz(static_cast<int>(l)), alone.layerXyz(static_cast<int>(l))))
                << size << " ranks, layer " << alone.layerNames()[l];
        ASSERT_EQ(root.tallies().size(), alone.tallies().size());
        for (size_t t = 0; t < alone.tallies().size(); ++t) {
            EXPECT_EQ(root.tallyPowerW(root.tallies()[t]), alone.tallyPowerW(alone.tallies()[t])) << t;
            EXPECT_EQ(root.tallyStandardErrorW(root.tallies()[t]), alone.tallyStandardErrorW(alone.tallies()[t])) << t;
        }
        EXPECT_EQ(root.estimatedRelativeError(kGroupFlare), alone.estimatedRelativeError(kGroupFlare));
        const RenderStatistics &a = alone.statistics(), &b = root.statistics();
        EXPECT_EQ(b.photons, a.photons);
        EXPECT_EQ(b.sensorHits, a.sensorHits);
        EXPECT_EQ(b.beams, a.beams);
        EXPECT_EQ(b.beamRays, a.beamRays);
        EXPECT_EQ(b.unguidedEnteredPowerW, a.unguidedEnteredPowerW);
        EXPECT_EQ(b.passes, a.passes);
        EXPECT_EQ(root.passPlan(), plan);
        for (int r = 1; r < size; ++r) EXPECT_EQ(renderers[r]->statistics().passes, kPasses);
    }
}

// Ranks claiming jobs from a shared counter in chunks of claimChunk (PassExchange.h, as
// RenderDistributed.cpp claims them: the counter read, then the chunk for what is left claimed),
// each claiming again as soon as its chunk is traced, simulated in time with job costs drawn in
// [0.5, 1.5] ms and rank 0 starting late (it ends the last pass first, in less than a pass): every job is traced exactly
// once, and the ranks end their tracing within 2 jobs' time of each other. Why: a rank's claim
// that fails comes after the last claim that succeeded, so the spread is at most the last chunk's
// time. A chunk of c ≤ m/(4R) + threads jobs, claimed with m left, is followed by m − c jobs that
// the R ranks share, which last longer than it while (m − c)·0.5 ≥ R·c·1.5 (costs at most 3 to
// 1), so the last chunk is one claimed with m < 4R·2·threads: at most 2 jobs per thread.
TEST(RenderDistributed, ClaimedChunksTraceEveryJobOnceAndEndTogether) {
    EXPECT_EQ(claimChunk(1000, 2, 1), 125);
    EXPECT_EQ(claimChunk(1000, 2, 4), 128);  // whole jobs per thread
    EXPECT_EQ(claimChunk(3, 2, 1), 1);
    EXPECT_EQ(claimChunk(0, 2, 4), 4);
    EXPECT_EQ(claimChunk(-5, 3, 1), 1);
    std::uint64_t state = 12345;
    auto uniform = [&](double lo, double hi) {
        state = state * 6364136223846793005ULL + 1442695040888963407ULL;
        return lo + (hi - lo) * static_cast<double>(state >> 11) * 0x1.0p-53;
    };
    double widest = 0.0;
    for (int trial = 0; trial < 400; ++trial) {
        const int ranks = 2 + trial % 4, threads = 1 + (trial / 4) % 3;
        const long jobs = trial % 10 == 0 ? trial % 7 : 100 + static_cast<long>(uniform(0.0, 3000.0));
        std::vector<double> cost(static_cast<size_t>(jobs));
        for (double& c : cost) c = uniform(0.5e-3, 1.5e-3);
        // A rank traces a chunk on its threads, the jobs dealt to them in turn: the chunk takes its
        // costliest thread's time.
        std::vector<double> freeAt(static_cast<size_t>(ranks), 0.0), doneAt(static_cast<size_t>(ranks), -1.0);
        // (Late by up to 0.6 of a balanced pass: the others, tracing alone meanwhile, leave it jobs.)
        freeAt[0] = uniform(0.0, 0.6) * static_cast<double>(jobs) * 1e-3 / (ranks * threads);
        std::vector<int> tracedBy(static_cast<size_t>(jobs), -1);
        long counter = 0;
        for (int active = ranks; active > 0;) {
            int r = -1;  // the rank free first claims next
            for (int q = 0; q < ranks; ++q)
                if (doneAt[q] < 0.0 && (r < 0 || freeAt[q] < freeAt[r])) r = q;
            const long count = claimChunk(jobs - counter, ranks, threads);
            ASSERT_GE(count, threads);
            ASSERT_EQ(count % threads, 0);
            const long first = counter;
            counter += count;
            if (first >= jobs) {
                doneAt[r] = freeAt[r];
                --active;
                continue;
            }
            std::vector<double> perThread(static_cast<size_t>(threads), 0.0);
            for (long j = first; j < std::min(jobs, first + count); ++j) {
                ASSERT_EQ(tracedBy[j], -1) << "job " << j << " claimed twice";
                tracedBy[j] = r;
                perThread[static_cast<size_t>((j - first) % threads)] += cost[j];
            }
            freeAt[r] += *std::max_element(perThread.begin(), perThread.end());
        }
        for (long j = 0; j < jobs; ++j) ASSERT_GE(tracedBy[j], 0) << "job " << j << " never traced";
        const auto [first, last] = std::minmax_element(doneAt.begin(), doneAt.end());
        widest = std::max(widest, *last - *first);
        EXPECT_LE(*last - *first, 2 * 1.5e-3 + 1e-12)
            << trial << ": " << ranks << " ranks of " << threads << " threads, " << jobs << " jobs";
    }
    RecordProperty("widest_spread_ms", std::to_string(widest * 1e3));
}

}  // namespace
}  // namespace flare
