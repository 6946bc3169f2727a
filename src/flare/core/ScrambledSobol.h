// Owen-scrambled Sobol' points, drawn by index: the beams' samples (src/flare/render).
//
// The Sobol' sequence (boost::random::sobol, Joe and Kuo's direction numbers) is stratified: its
// first 2^m points put one point in every elementary interval of volume 2^−m (up to its t-value),
// and so does every later aligned block of 2^m points, so an average over a prefix converges
// faster than one over the square root of its length. Nested uniform scrambling (Owen 1995) flips
// each binary digit of each coordinate with a coin that depends on the seed, the dimension, the
// digit's position and the unscrambled digits above it. Every scrambled point is then uniform on
// the unit cube (an average over any prefix is unbiased), the stratification is kept (a coin is
// shared by all the points of one interval, so they move together), and different seeds give
// independent sequences: independent replicates, whose spread estimates the error of their mean.
// The coins are hashes, so point i costs the same whatever i.
#pragma once

#include <cstdint>

namespace flare {

class ScrambledSobol {
public:
    static constexpr int kMaxDimensions = 8;

    // Throws std::invalid_argument unless 1 ≤ dimensions ≤ kMaxDimensions.
    ScrambledSobol(int dimensions, std::uint64_t seed);

    int dimensions() const { return dimensions_; }
    // Writes point `index` of the scrambled sequence to out[0 .. dimensions), each in [0, 1) with
    // 53 bits.
    void point(std::uint64_t index, double* out) const;

    // The scramble of one coordinate's 64 binary digits (the unit interval in 2^−64 steps), for
    // the tests: a bijection of the integers that maps each aligned block of 2^k onto another.
    static std::uint64_t scramble(std::uint64_t digits, std::uint64_t dimensionSeed);

private:
    int dimensions_;
    std::uint64_t dimensionSeeds_[kMaxDimensions];
};

}  // namespace flare
