// Tracing a bundle of parallel rays along one fixed ghost path, step-major: every ray of a small
// batch meets surface k before any ray meets the next surface. The result for each ray is exactly
// tracePath's (same primitives, same order of operations; a test checks it bit for bit), but the
// step's data stay in cache and the long dependency chains of consecutive rays (divisions, square
// roots, sincos) overlap, which a ray-at-a-time loop cannot do.
//
// The path is also exposed step by step (advance), with each step's constraint as a continuous
// margin, so that PupilMesh can follow the set of surviving rays from surface to surface.
#pragma once

#include <span>
#include <vector>

#include <glm/vec2.hpp>

#include "flare/optics/PupilGrid.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {

// Where one ray of the bundle ended.
struct BundleLanding {
    glm::dvec2 sensorMm{0.0};  // on the sensor plane (valid when ok())
    double throughput = 0.0;   // as tracePath: the product of the factors, 0 on failure
    TraceStatus status = TraceStatus::Missed;
    int surface = -1;          // where the trace ended (surfaceCount: the sensor)

    bool ok() const { return status == TraceStatus::Ok; }
    // Landed inside the sensor rectangle (what the ghost analysis counts as live).
    bool onSensor(const LensSystem& lens) const;
};

// A ray part-way along the path.
struct BundleRay {
    Ray ray;
    double throughput = 1.0;
};

// What one step did to a ray.
struct StepOutcome {
    bool alive = true;
    TraceStatus failure = TraceStatus::Ok;
    // The step's constraint as (x/x_max)² − 1, ≤ 0 exactly when the step passes (up to rounding):
    // the clear aperture (x = distance from the axis), the iris (Iris::margin), total internal
    // reflection (sin²θt − 1; the larger of the two at a refraction), the sensor rectangle at a
    // sensor reflection (max norm). NaN where the step has no such measure (a missed surface, a
    // wrong exit); −1 where it cannot fail.
    double margin = -1.0;
};

// The sensor rectangle's constraint in the form of StepOutcome::margin (max norm).
double sensorMargin(const LensSystem& lens, const glm::dvec2& sensorMm);

// The Fresnel/coating factors (interfaceResponse) of every interface of a lens at one wavelength,
// tabulated as functions of the incidence cosine for tracing many rays: the thin-film response
// costs a sincos and a dozen divisions, a table lookup a few multiplications. Cubic Hermite
// interpolation on 1024 intervals; within a few intervals of the critical angle of total
// internal reflection (where the response has a square-root edge) the exact response is used.
// The tables agree with interfaceResponse to about 1e-12 relative (checked in the tests). Fewer
// intervals build faster for a one-off wavelength (the final render's beams use 64).
class InterfaceTables {
public:
    static constexpr int kDefaultIntervals = 1024;
    // An interface met by a path: a surface and the direction of travel (+1 towards the sensor).
    struct Interface {
        int surface = 0, direction = 1;
    };
    // With `only` (e.g. BundleTracer::interfaces()), just those interfaces are tabulated (a beam's
    // one-off tables then cost a path's share of the lens); others fall back to the exact response.
    // The slopes come from central differences of the response (three responses per point: the
    // 1e-12 agreement above); with `slopesFromValues`, from the tabulated values themselves (one
    // response per point, a third of the cost, for coarse one-off tables whose own error is larger
    // anyway; see test_bundle_tracer.cpp for both errors).
    InterfaceTables(const LensSystem& lens, const SpectralIndices& indices, int intervals = kDefaultIntervals,
                    std::span<const Interface> only = {}, bool slopesFromValues = false);
    // interfaceResponse(lens, indices, surface, direction, cosThetaI).reflectance() / .transmittance().
    double reflectance(int surface, int direction, double cosThetaI) const;
    double transmittance(int surface, int direction, double cosThetaI) const;

private:
    friend class PacketTracer;  // interpolates the tables in SIMD lanes

    struct Table {
        std::vector<double> value, slope;  // at cos = i / intervals_
        double exactFrom = 2.0, exactTo = -1.0;  // evaluate exactly in this range of cosines
    };
    double lookup(const Table& t, int surface, int direction, bool reflect, double cosThetaI) const;
    const Table& table(int surface, int direction, bool reflect) const {
        return tables_[(static_cast<size_t>(surface) * 2 + (direction > 0 ? 1 : 0)) * 2 + (reflect ? 1 : 0)];
    }

    const LensSystem* lens_;
    SpectralIndices indices_;
    int intervals_ = kDefaultIntervals;
    std::vector<Table> tables_;  // per surface, direction, reflect/transmit
};

class BundleTracer {
public:
    // The path from object space to the sensor reflecting at `reflections` (as GhostPath), at one
    // wavelength. fresnelWeights = false gives geometry only (throughput 1 for surviving rays),
    // like TraceOptions::fresnelWeights. The lens must outlive the tracer.
    // With `tables` (which must outlive the tracer), the Fresnel/coating factors come from them
    // instead of interfaceResponse: faster, equal to about 1e-12 relative.
    BundleTracer(const LensSystem& lens, const SpectralIndices& indices, std::span<const int> reflections,
                 bool fresnelWeights = true, const InterfaceTables* tables = nullptr);

    // out[i] = the landing of grid.ray(pupilMm[i].x, pupilMm[i].y): status, surface, throughput and
    // (for ok rays) sensorMm equal tracePath's with default TraceOptions (or fresnelWeights =
    // false); bit for bit without tables.
    void trace(const PupilGrid& grid, std::span<const glm::dvec2> pupilMm, std::span<BundleLanding> out) const;
    BundleLanding trace(const PupilGrid& grid, const glm::dvec2& pupilMm) const;

    // Step by step: stepCount() events, the last of which ends on the sensor plane (a ray alive
    // after it has rays[i].ray.originMm on the sensor). Applies step `step` to every ray (all must
    // be alive) and writes its outcome; with margins = false, the margins are not computed.
    int stepCount() const { return static_cast<int>(steps_.size()); }
    void advance(int step, std::span<BundleRay> rays, std::span<StepOutcome> outcomes, bool margins) const;
    // The surface (index; surfaceCount for the sensor) a step meets, for reports.
    int stepSurface(int step) const { return steps_[step].surface; }
    // The interfaces the path refracts or reflects at (each once), for InterfaceTables' `only`.
    std::vector<InterfaceTables::Interface> interfaces() const;

    // The same path without Fresnel/coating factors: the same geometry, cheaper, for searches that
    // need only which rays survive.
    BundleTracer geometryOnly() const;

    const LensSystem& lens() const { return *lens_; }
    double wavelengthNm() const { return indices_.wavelengthNm; }
    bool fresnelWeights() const { return fresnelWeights_; }
    // The path's reflections, as given.
    std::span<const int> reflections() const { return reflections_; }

private:
    friend class PacketTracer;  // runs the same steps in SIMD lanes

    struct Step {
        enum class Kind : std::uint8_t { Refract, Reflect, Stop, SensorEnd, SensorReflect, SensorWrongExit, WrongExit };
        Kind kind = Kind::Refract;
        int surface = 0;     // index k (surfaceCount for the sensor, −1 for the front)
        int direction = 1;   // of travel before the event
        double n1 = 1.0, n2 = 1.0;
        bool weighted = true;  // multiply by the Fresnel/coating factor
        bool sphere = false;   // the surface is a plain sphere (inline intersection and normal)
    };
    void applyStep(const Step& s, BundleRay* rays, StepOutcome* outcomes, int count, bool margins) const;

    const LensSystem* lens_;
    SpectralIndices indices_;
    std::vector<Step> steps_;
    std::vector<int> reflections_;
    bool fresnelWeights_;
    const InterfaceTables* tables_;
};

}  // namespace flare
