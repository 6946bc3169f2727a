// PacketTracer's vector kernel: one step of a path (a surface, the iris or the sensor) for a batch
// of rays in the lanes of SIMD registers, compiled once per instruction set (Google Highway's
// foreach_target) and run on the widest the processor has (dynamic dispatch). Internal to
// PacketTracer (PacketTracer.h), which builds the steps, fills the lanes, runs the scalar code for
// what a step leaves to it and moves the rays between steps.
//
// Every operation is BundleTracer::applyStep's, in its order (PacketKernel.cpp is compiled with
// -ffp-contract=off: no fused multiply-adds), so each lane's ray ends, lands and is weighed as
// tracePath's to the last bit.
#pragma once

#include <cstddef>
#include <cstdint>

#include "flare/optics/SequentialTracer.h"

namespace flare::detail {

// One event of the path with the constants its vector kernel needs (PacketTracer builds them).
struct PacketStep {
    enum class Kind : std::uint8_t {
        Conic,      // refraction or reflection at a sphere, conic or plane
        Stop,       // the iris plane
        Sensor,     // the sensor plane: end there, reflect, or a wrong exit
        Scalar,     // BundleTracer's step for every ray (an aspheric iris plane)
        WrongExit,  // every ray ends here
    };
    Kind kind = Kind::Conic;
    bool reflect = false;        // Conic: mirror reflection; Sensor: reflect off the sensor
    bool wrongExit = false;      // Sensor: rays reaching it end as WrongExit
    bool weighted = false;       // Conic: multiply by the Fresnel/coating factor
    // Conic, rays at wavelengths of their own: a factor applies (the path has them); each lane
    // then decides as tracePath does (a refraction between equal indices has none).
    bool laneWeighted = false;
    enum class Normal : std::uint8_t { Sphere, Plane, Conic } normal = Normal::Sphere;  // Conic
    bool sensorWeighted = false; // Sensor reflection: multiply by the sensor's reflectance
    bool roundIris = true;       // Stop
    int surface = 0, direction = 1;  // as BundleTracer's step (for the Fresnel/coating factor)
    double vertexZMm = 0.0, curvaturePerMm = 0.0, conicFactor = 1.0, radiusMm = 0.0;
    double centreZMm = 0.0;       // a sphere's centre of curvature
    // An asphere (Normal::Conic with polynomial terms): intersect()'s Newton iteration in the
    // lanes; its A4..A16 and their slope coefficients (i + 2) A_{2i+4}.
    bool polynomial = false;
    double asphere[kAsphereTerms] = {}, slopeCoefficient[kAsphereTerms] = {};
    double aperture2Mm2 = 0.0, inverseAperture2PerMm2 = 0.0;  // the clear aperture's semi-diameter squared
    double eta = 1.0;             // n1 / n2
    double irisInner2Mm2 = 0.0;   // Stop: squared radius within which every point passes
    double irisOuter2Mm2 = 0.0;   // Stop: beyond it none passes (between: the scalar test)
    // Stop, a polygonal iris of at most kLaneBlades blades: Iris::margin in the lanes (more blades
    // take the scalar step when margins are asked).
    static constexpr int kLaneBlades = 16;
    int blades = 0;
    double edgeNormalX[kLaneBlades] = {}, edgeNormalY[kLaneBlades] = {};
    double apothemMm = 0.0, arcCentreMm = 0.0, arcRadiusMm = 0.0;
    double sensorZMm = 0.0, halfWidthMm = 0.0, halfHeightMm = 0.0, sensorReflectance = 1.0;
    // Conic, weighted, with InterfaceTables: the factor's table (values and slopes at cos = i /
    // intervals), looked up in the lanes; cosines in [exactFrom, exactTo] get the exact response.
    const double* tableValue = nullptr;
    const double* tableSlope = nullptr;
    double tableIntervals = 0.0, tableExactFrom = 2.0, tableExactTo = -1.0;
};

// Rays per batch: every array of the batch stays in L1 (11 × 1 KiB), and the kernel's loop over
// a step has 16 to 128 independent iterations, enough to overlap the divisions and square roots.
inline constexpr int kPacketBatch = 128;
// The widest vector holds 8 doubles (AVX-512): batches are padded to a multiple of it.
inline constexpr int kPacketMaxLanes = 8;

// The state of a batch of rays, one array per coordinate (structure of arrays), so that a vector
// register loads consecutive rays' x, then their y, and so on.
struct PacketLanes {
    alignas(64) double ox[kPacketBatch], oy[kPacketBatch], oz[kPacketBatch];
    alignas(64) double dx[kPacketBatch], dy[kPacketBatch], dz[kPacketBatch];
    alignas(64) double throughput[kPacketBatch];
    // 0 while the ray is going; else 1 + status + 8 × (the step where it ended).
    alignas(64) double fate[kPacketBatch];
    // Set by a vector step for rays it left unchanged for the scalar step (1), else 0.
    alignas(64) double deferred[kPacketBatch];
    // The incidence cosine at a weighted step, and 1 where its Fresnel/coating factor is left to
    // the scalar code (no tables, or a cosine in the tables' exact zone).
    alignas(64) double cosine[kPacketBatch];
    alignas(64) double scalarWeight[kPacketBatch];
    // The step's constraint as StepOutcome::margin (when the step is asked for margins).
    alignas(64) double margin[kPacketBatch];
    // n1 / n2 of each lane's own wavelength at a refraction (rays at wavelengths of their own).
    alignas(64) double eta[kPacketBatch];
};

// Which margins a step writes: none (trace), those BundleTracer::advance gives without margins
// (a clear aperture's, −1 through the iris), or all of them (the iris's, total internal
// reflection's too).
enum class PacketMargins : std::uint8_t { None, Cheap, All };

// What a vector step left to the scalar code (flags), and how many rays it left going.
inline constexpr int kDeferredRays = 1, kScalarWeights = 2;
struct PacketStepResult {
    int left = 0;
    int going = 0;  // not counting the deferred rays
};

inline double fateCode(int step, TraceStatus status) { return 1.0 + static_cast<double>(status) + 8.0 * step; }
// The status part of a fate that no TraceStatus uses: a ray at a wavelength of its own that a
// refracting step left to the scalar code, to be traced again by tracePath.
inline constexpr int kRetraceStatus = 7;
static_assert(static_cast<int>(TraceStatus::WrongExit) < kRetraceStatus);
inline double retraceCode(int step) { return 1.0 + kRetraceStatus + 8.0 * step; }

// The step `s` (number `step`, for the fates) for the first `count` lanes of `b` (a multiple of
// kPacketMaxLanes) on the best instruction set: the rays' new state, their fates, their margins
// (as `margins` asks) and what is left to the scalar code. With `ownIndices` (rays at wavelengths
// of their own), a refraction takes each lane's n1 / n2 from b.eta and every factor of a
// laneWeighted step is left to the scalar code.
PacketStepResult advancePacket(const PacketStep& s, int step, PacketLanes& b, std::size_t count,
                               PacketMargins margins, bool ownIndices);

// The instruction set advancePacket runs on, e.g. "AVX3" (AVX-512) or "AVX2".
const char* packetTargetName();

}  // namespace flare::detail
