// A BundleTracer's path traced in SIMD packets: the lanes of one vector register carry that many
// parallel rays through each event at once, in double precision, on the widest instruction set
// the processor has (Google Highway's dynamic dispatch: AVX-512, AVX2, SSE4, or the baseline).
// The operations and their order are tracePath's (no fused multiply-adds, no reciprocal
// approximations), so every ray's status, surface, throughput and landing equal tracePath's to
// the last bit on every instruction set; a test checks it lane by lane for each one this
// processor runs.
//
// Spheres, conics, planes and aspheres (intersect()'s Newton iteration, each lane stopping where
// it would) are traced in the vector lanes; the few rays whose origin is too far from a conic for
// its quadratic (intersectConicFromAfar) and rays near the blades of a polygonal iris take
// BundleTracer's scalar step for that event. Fresnel/coating factors from
// InterfaceTables are interpolated in the lanes with the same operations as the tables' own
// lookup; the exact responses (no tables, or a cosine near total internal reflection) are
// evaluated one lane at a time.
//
// The vector step itself, compiled per instruction set, is PacketKernel.h's; this class builds the
// steps from the path, runs them batch after batch, does what they leave to the scalar code and
// moves the going rays together as others end.
#pragma once

#include <span>
#include <vector>

#include <glm/vec2.hpp>

#include "flare/optics/BundleTracer.h"
#include "flare/optics/PacketKernel.h"

namespace flare {

class PacketTracer {
public:
    // The path of `path` (a copy is kept, with the lens, indices and tables it refers to, which
    // must outlive this tracer).
    explicit PacketTracer(const BundleTracer& path);

    // As BundleTracer::trace: out[i] = the landing of grid.ray(pupilMm[i].x, pupilMm[i].y), bit for
    // bit tracePath's (with the BundleTracer's tables, equal to BundleTracer's).
    void trace(const PupilGrid& grid, std::span<const glm::dvec2> pupilMm, std::span<BundleLanding> out) const;

    // Where and why a ray of advance() ended: the step, −1 if it went through every step asked.
    struct End {
        int step = -1;
        TraceStatus status = TraceStatus::Ok;
    };

    // tracePath for rays each at a wavelength of its own (the final render's guided photons):
    // out[i] = the landing of tracePath(lens, *indices[i], rays[i], the path), with its factors if
    // the path has them, bit for bit. The path's own wavelength and tables are not used: each lane
    // refracts with its ray's indices and gets its Fresnel/coating factor exactly, one lane at a
    // time. The rare rays the lanes leave to the scalar code at a refracting surface (an origin
    // beyond kConicFarOrigin radii of a conic) are traced by tracePath itself.
    void trace(std::span<const Ray> rays, std::span<const SpectralIndices* const> indices,
               std::span<BundleLanding> out) const;

    // BundleTracer::advance for the steps first..last in turn, for rays all going at `first`,
    // which stay in the vector lanes from step to step: a ray that goes through them all leaves
    // as BundleTracer::advance, step after step, would leave it, to the last bit; one that ends
    // keeps its state from before the call, and ends[i] says where and why. With `margins` (one
    // row per ray, indexed by step, or empty for none), margins[i][k] receives the
    // StepOutcome::margin of step k for every step the ray entered, the bits
    // BundleTracer::advance(k, …, true) gives.
    void advance(int first, int last, std::span<BundleRay> rays, std::span<End> ends,
                 std::span<double* const> margins) const;
    int stepCount() const { return path_.stepCount(); }

    const BundleTracer& path() const { return path_; }
    // The instruction set the dispatcher chose on this processor, e.g. "AVX3" (AVX-512) or "AVX2".
    static const char* targetName();

private:
    void scalarWeights(const detail::PacketStep& s, detail::PacketLanes& b, int active) const;
    // Step `step` for the going lanes of a batch (its first `active` lanes), with their margins
    // when asked; returns how many are still going.
    int runStep(int step, detail::PacketLanes& b, int active, bool margins) const;
    // Both trace()s: the rays rayAt(0 .. count − 1), at the path's wavelength or, with
    // kOwnIndices, each at its own (indices[i]).
    template <bool kOwnIndices, class RayAt>
    void traceRays(size_t count, const RayAt& rayAt, std::span<const SpectralIndices* const> indices,
                   std::span<BundleLanding> out) const;
    // runStep for rays at their own wavelengths: lane i's ray is input index[i] (−1: padding),
    // whose indices are indices[index[i]]. Rays a refracting step leaves to the scalar code end
    // with the fate kRetraceStatus (traced again by tracePath).
    int runStepOwnIndices(int step, detail::PacketLanes& b, int active, const int* index,
                          std::span<const SpectralIndices* const> indices) const;

    BundleTracer path_;
    std::vector<detail::PacketStep> steps_;
};

}  // namespace flare
