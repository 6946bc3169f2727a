#include "flare/core/ScrambledSobol.h"

#include <stdexcept>
#include <string>

#include <boost/random/sobol.hpp>

#include "flare/core/Random.h"

namespace flare {

ScrambledSobol::ScrambledSobol(int dimensions, std::uint64_t seed) : dimensions_(dimensions), dimensionSeeds_{} {
    if (dimensions < 1 || dimensions > kMaxDimensions)
        throw std::invalid_argument("ScrambledSobol: dimensions must be in [1, " + std::to_string(kMaxDimensions) + "]");
    for (int d = 0; d < dimensions; ++d) dimensionSeeds_[d] = mixBits(seed ^ mixBits(static_cast<std::uint64_t>(d) + 1));
}

std::uint64_t ScrambledSobol::scramble(std::uint64_t digits, std::uint64_t dimensionSeed) {
    // Digit 63 is the most significant (1/2). The coin of a digit depends on the digits above it
    // (the elementary interval the point lies in at that depth) and on the depth; the depth is
    // mixed in separately so that the empty prefix of one depth is not another's.
    std::uint64_t out = 0;
    for (int bit = 63; bit >= 0; --bit) {
        const std::uint64_t above = bit == 63 ? 0 : digits >> (bit + 1);
        const std::uint64_t coin = mixBits(dimensionSeed ^ mixBits(above ^ (static_cast<std::uint64_t>(bit) << 58))) & 1u;
        out |= (((digits >> bit) & 1u) ^ coin) << bit;
    }
    return out;
}

void ScrambledSobol::point(std::uint64_t index, double* out) const {
    // boost's engine returns one coordinate per call, all 64 digits of each; seeding it with i
    // jumps directly (Gray code, O(dimensions × 64)) to the sequence's point i + 1: it leaves out
    // the origin, point 0, without which no block of 2^m points would be aligned.
    boost::random::sobol sobol(static_cast<unsigned>(dimensions_));
    if (index > 0) sobol.seed(static_cast<boost::uintmax_t>(index - 1));
    for (int d = 0; d < dimensions_; ++d) {
        const std::uint64_t digits = index > 0 ? static_cast<std::uint64_t>(sobol()) : 0;
        out[d] = static_cast<double>(scramble(digits, dimensionSeeds_[d]) >> 11) * 0x1.0p-53;
    }
}

}  // namespace flare
