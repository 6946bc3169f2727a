// A render's passes shared among ranks (PassExchange.h), with the ranks simulated by threads of
// this process: rank 0's film, tallies and statistics are bitwise one renderer's, for 2 and 3
// ranks, with beams, guided and unguided photons and a dusty lens (every kind of job and hit).
// Runs in every build, with or without MPI (the CLI tests run the MPI transport itself).
#include <algorithm>
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

private:
    int size_;
    std::vector<std::deque<std::vector<char>>> queues_ = std::vector<std::deque<std::vector<char>>>(size_);
    std::mutex mutex_;
    std::condition_variable arrived_;
    std::vector<std::vector<std::vector<char>>> mail_ = std::vector<std::vector<std::vector<char>>>(size_);
    std::vector<int> values_;
    std::barrier<> meet_;
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

// Every job of a pass is traced by exactly one rank: rank 0 by its share, ⌊jobs · share⌋ of them
// spread evenly, the others the rest, dealt in turn so that their counts differ by at most one.
TEST(RenderDistributed, EveryJobHasOneRankAndRankZeroItsShare) {
    for (int size : {2, 3, 5})
        for (int share = 0; share <= kShareSteps / size; ++share)
            for (long jobs : {0L, 1L, 47L, 1040L}) {
                std::vector<long> count(static_cast<size_t>(size), 0);
                long rootInFirstHalf = 0;
                for (long j = 0; j < jobs; ++j) {
                    const int rank = jobRank(j, share, size);
                    ASSERT_GE(rank, 0);
                    ASSERT_LT(rank, size);
                    ++count[static_cast<size_t>(rank)];
                    if (rank == 0 && j < jobs / 2) ++rootInFirstHalf;
                }
                EXPECT_EQ(count[0], jobs * share / kShareSteps) << size << " " << share << " " << jobs;
                const auto [least, most] = std::minmax_element(count.begin() + 1, count.end());
                EXPECT_LE(*most - *least, 1) << size << " " << share << " " << jobs;
                // Spread: half the jobs hold half of rank 0's, to within one.
                EXPECT_LE(std::abs(2 * rootInFirstHalf - count[0]), 2) << size << " " << share << " " << jobs;
            }
    EXPECT_EQ(jobRank(5, 0, 1), 0);
}

// Rank 0's share balances its time to the next exchange with each other rank's: to within half a
// step of the share (the rounding), unless the balance lies outside [0, an equal share].
TEST(RenderDistributed, RankZerosShareBalancesItsTimeWithEachOtherRanks) {
    // Equal costs and nothing else to do: an equal share; a merge of 0.2 s with 2 ranks of 1 ms
    // per job, 1000 jobs: 0.2 + s = 1 − s, s = 0.4 (25.6 steps).
    EXPECT_EQ(balancedShare(1000, 2, 1e-3, 1e-3, 0.0), kShareSteps / 2);
    EXPECT_EQ(balancedShare(1000, 2, 1e-3, 1e-3, 0.2), 26);
    EXPECT_EQ(balancedShare(1000, 2, 1e-3, 1e-3, 5.0), 0);  // a merge longer than the pass: none
    EXPECT_EQ(balancedShare(1000, 4, 1e-4, 1e-3, 0.0), kShareSteps / 4);  // cheaper jobs: at most equal
    std::uint64_t state = 12345;
    auto uniform = [&](double lo, double hi) {
        state = state * 6364136223846793005ULL + 1442695040888963407ULL;
        return lo + (hi - lo) * static_cast<double>(state >> 11) * 0x1.0p-53;
    };
    for (int trial = 0; trial < 2000; ++trial) {
        const int size = 2 + trial % 7;
        const long jobs = 10 + static_cast<long>(uniform(0.0, 5000.0));
        const double rootPerJob = uniform(1e-4, 2e-3), otherPerJob = uniform(1e-4, 2e-3);
        const double rootFirst = uniform(0.0, 0.5 * jobs * otherPerJob / (size - 1));
        const int steps = balancedShare(jobs, size, rootPerJob, otherPerJob, rootFirst);
        ASSERT_GE(steps, 0);
        ASSERT_LE(steps, kShareSteps / size);
        const double s = static_cast<double>(steps) / kShareSteps;
        const double root = rootFirst + s * jobs * rootPerJob;
        const double other = (1.0 - s) * jobs * otherPerJob / (size - 1);
        // Half a step of the share moves the difference by half a step's jobs at both costs.
        const double halfStep = 0.5 / kShareSteps * jobs * (rootPerJob + otherPerJob / (size - 1));
        if (steps > 0 && steps < kShareSteps / size)
            EXPECT_LE(std::abs(root - other), halfStep * (1 + 1e-9)) << trial;
        else if (steps == 0)
            EXPECT_GE(root + halfStep * (1 + 1e-9), other) << trial;  // even none leaves rank 0 the longer
        else
            EXPECT_LE(root, other + halfStep * (1 + 1e-9)) << trial;  // an equal share leaves rank 0 the shorter
    }
}

}  // namespace
}  // namespace flare
