// Deterministic random numbers for the photon tracer. Every batch of photons owns a generator
// seeded from (render seed, batch index), so a batch draws the same numbers whichever thread
// traces it and in whatever order: the image depends on the seed only, never on the thread count.
// The generator is a permuted congruential generator (64-bit LCG state, 32-bit output with a
// random rotation; O'Neill 2014), small and fast, with independent streams chosen by the increment.
#pragma once

#include <cstdint>

namespace flare {

// SplitMix64 finaliser: spreads nearby seeds (batch 0, 1, 2, ...) over the whole 64-bit range.
inline std::uint64_t mixBits(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

class Rng {
public:
    Rng(std::uint64_t seed, std::uint64_t stream)
        : state_(0), increment_((mixBits(stream ^ 0x5851f42d4c957f2dull) << 1) | 1u) {
        next();
        state_ += mixBits(seed);
        next();
    }

    std::uint32_t next() {
        const std::uint64_t old = state_;
        state_ = old * 6364136223846793005ull + increment_;
        const auto xorShifted = static_cast<std::uint32_t>(((old >> 18) ^ old) >> 27);
        const auto rotation = static_cast<std::uint32_t>(old >> 59);
        return (xorShifted >> rotation) | (xorShifted << ((32u - rotation) & 31u));
    }

    // Uniform in [0, 1) with 53 random bits (two outputs), never exactly 1.
    double uniform() {
        const std::uint64_t hi = next(), lo = next();
        return static_cast<double>(((hi << 32) | lo) >> 11) * 0x1.0p-53;
    }

private:
    std::uint64_t state_;
    std::uint64_t increment_;
};

}  // namespace flare
