// Exact (real-ray) sequential tracing through a LensSystem: forward to the sensor, backward to
// object space, or along a prescribed sequence of reflections (a ghost path). A ray that misses
// a surface, leaves a clear aperture, is stopped by the iris or meets total internal reflection
// where it should refract ends with a status and zero throughput; nothing here throws or allocates.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "flare/core/Ray.h"
#include "flare/optics/LensSystem.h"

namespace flare {

enum class TraceStatus : std::uint8_t {
    Ok,
    Missed,                   // the ray does not meet the next surface
    Vignetted,                // outside a clear aperture (it would hit the edge or the barrel)
    BlockedByIris,
    TotalInternalReflection,  // where the path asks for a transmission
    NewtonDiverged,           // asphere intersection did not converge
    WrongExit,                // left the lens on the wrong side for the requested path
};

const char* toString(TraceStatus status);

struct TraceResult {
    Ray ray;                 // at the last event: on the sensor, or just outside the front surface
    double throughput = 0.0; // product of the Fresnel/coating (and sensor) factors; 0 on failure
    TraceStatus status = TraceStatus::Missed;
    int surface = -1;        // where the trace ended (surfaceCount = the sensor)
    int interactions = 0;    // surface events, for statistics

    bool ok() const { return status == TraceStatus::Ok; }
};

struct TraceOptions {
    bool clipApertures = true;   // clear apertures and the iris
    bool fresnelWeights = true;  // multiply throughput by Fresnel/coating factors
    // Optional: every point where the ray meets a surface or the sensor, for drawings.
    std::vector<glm::dvec3>* pathPointsMm = nullptr;
    // Optional, alongside pathPointsMm: the surface of each point (−1 the start, surfaceCount the
    // sensor), so that a caller knows which medium each segment crossed.
    std::vector<int>* pathSurfaces = nullptr;
};

// Where a sequential path starts and ends. Surfaces are 0-based in file order (counting the stop);
// the index surfaceCount denotes the sensor.
struct SequentialPath {
    enum class End { Sensor, ObjectSpace };
    int start = -1;     // −1: object space, surfaceCount: the sensor plane
    int direction = 1;  // +1 towards the sensor, −1 towards the object
    std::span<const int> reflections;  // surfaces (or the sensor) where the ray reflects, in order
    End end = End::Sensor;
};

// Object space → sensor plane, refracting at every surface.
TraceResult traceForward(const LensSystem& lens, const SpectralIndices& indices, const Ray& ray,
                         const TraceOptions& options = {});
// Image space → object space, refracting at every surface (the ray starts behind the last surface
// travelling towards −z; the result is the ray just in front of the first surface).
TraceResult traceBackward(const LensSystem& lens, const SpectralIndices& indices, const Ray& ray,
                          const TraceOptions& options = {});
// A prescribed sequence of reflect/transmit events.
TraceResult tracePath(const LensSystem& lens, const SpectralIndices& indices, const Ray& ray,
                      const SequentialPath& path, const TraceOptions& options = {});

// Fresnel or thin-film response of surface k for light travelling in `direction` (+1/−1) with the
// given incidence cosine.
FresnelTerms interfaceResponse(const LensSystem& lens, const SpectralIndices& indices, int k,
                               int direction, double cosThetaI);
// An upper bound on interfaceResponse(...).reflectance() (thinFilmReflectanceBound), with the
// rounding of both sides allowed for: bound · (1 + kReflectanceBoundMargin) +
// kReflectanceBoundFloor (both the bound and the response are within a few ulps; the margin is
// far wider). 1 where there is none (uncoated, several layers, ideal).
inline constexpr double kReflectanceBoundMargin = 1e-9, kReflectanceBoundFloor = 1e-12;
double interfaceReflectanceBound(const LensSystem& lens, const SpectralIndices& indices, int k, int direction,
                                 double cosThetaI);

}  // namespace flare
