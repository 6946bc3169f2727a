// Interleaved replicates: the unit of independence of a render whose passes are not independent.
//
// A render's beams continue one scrambled Sobol' sequence from pass to pass (ScrambledSobol.h), so
// that its error falls faster than one over the square root of its passes; its passes are then
// correlated, and their spread says nothing about the error. So the render runs K independent
// sequences (replicates), pass p extending replicate p mod K, and estimates the error from the
// spread of the replicates' means. With S_r the sum of replicate r's n_r passes, P = Σ n_r, the
// mean T = Σ S_r / P and M_r = S_r / n_r,
//     Var(T) ≈ Σ_r n_r (M_r − T)² / ((K − 1) P),
// which is unbiased when a replicate's variance falls as one over its passes (independent passes)
// and, since the n_r differ by at most one, within that difference otherwise.
#pragma once

#include <cstdint>

namespace flare {

// Each replicate keeps a full-frame sum per variance group (Film::setReplicates): the bound keeps
// that memory within 4× what independent passes need (their sum and sum of squares).
constexpr int kMaxReplicates = 8;

// The number of passes among the first `passes` that belong to replicate r of K.
inline std::int64_t replicatePasses(int r, std::int64_t passes, int replicates) {
    return passes / replicates + (r < passes % replicates ? 1 : 0);
}

// The estimated variance of the mean over passes of a quantity whose replicate r's sum is
// sums[r][offset] (a null array holds zeros: e.g. a pixel's channel in K images, some of whose
// tiles no pass of that replicate reached); 0 until every replicate has a pass.
inline double replicateVarianceOfMean(const double* const* sums, std::int64_t offset, int replicates,
                                      std::int64_t passes) {
    if (replicates < 2 || passes < replicates) return 0.0;
    double total = 0.0;
    for (int r = 0; r < replicates; ++r) total += sums[r] ? sums[r][offset] : 0.0;
    const double mean = total / static_cast<double>(passes);
    double spread = 0.0;
    for (int r = 0; r < replicates; ++r) {
        const double n = static_cast<double>(replicatePasses(r, passes, replicates));
        const double deviation = (sums[r] ? sums[r][offset] : 0.0) / n - mean;
        spread += n * deviation * deviation;
    }
    return spread / ((replicates - 1) * static_cast<double>(passes));
}

// The same for one quantity: its replicates' sums are sums[0 .. replicates).
inline double replicateVarianceOfMean(const double* sums, int replicates, std::int64_t passes) {
    const double* rows[kMaxReplicates];
    for (int r = 0; r < replicates && r < kMaxReplicates; ++r) rows[r] = sums + r;
    return replicates <= kMaxReplicates ? replicateVarianceOfMean(rows, 0, replicates, passes) : 0.0;
}

}  // namespace flare
