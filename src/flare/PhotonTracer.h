// Non-sequential photon tracing through a lens (the seed thesis's method): at every interface the
// photon reflects or refracts with the Fresnel/coating probability, may meet any surface in any
// order, and its bounce chain is unbounded. Besides the optical surfaces it meets the inside of the
// lens: the barrel wall of every air space, the ground edge of every element, the retaining rings
// that cover each surface outside its clear aperture, the iris blades, and the sensor, which
// reflects a little light back into the lens.
//
// The inside of the lens is a chain of cells: cell g lies between surface g−1 and surface g
// (cell 0 is object space, cell surfaceCount lies between the last surface and the sensor), closed
// at the side by a cylinder (the barrel in air, the element's edge in glass) and, where a surface
// ends before that cylinder, by a flat annulus at the surface's rim. A photon in cell g can only
// meet these few boundaries, so finding the next event costs two surface intersections, not n.
//
// Sampling is analog: every choice (reflect or refract, absorb or scatter at a wall) is made with
// its physical probability, so a photon's weight never changes and each photon ends in exactly
// one fate. That makes energy conservation a counting identity and keeps the tracer simple; the
// guided strategy (Render) is where variance is reduced.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>

#include "flare/LensSystem.h"
#include "flare/Random.h"
#include "flare/Ray.h"

namespace flare {

// Diffuse (Lambertian) albedo of the lens's inner parts; 0 is perfectly black. A photon that
// scatters off one of them is marked scattered and lands in the `scatter` layer.
struct InteriorMaterials {
    double housingAlbedo = 0.0;  // barrel walls, retaining rings, the camera body around the sensor
    double edgeAlbedo = 0.0;     // ground element edges (inside the glass)
    double irisAlbedo = 0.0;     // iris blades
};

// Reflection sequence of a path as one integer: the count in the top byte and up to 7 surface
// indices (0-based; surfaceCount = the sensor) one byte each. Longer sequences share kLongPathKey.
using PathKey = std::uint64_t;
inline constexpr int kPathKeyMaxReflections = 7;
inline constexpr PathKey kLongPathKey = ~PathKey{0};
PathKey pathKey(const std::vector<int>& reflections);

enum class PhotonFate : std::uint8_t {
    Escaped,          // left through the front (or never entered the lens)
    AbsorbedSensor,   // absorbed by the sensor (after being counted there)
    AbsorbedHousing,  // barrel, rings, camera body
    AbsorbedEdge,     // ground element edge
    AbsorbedIris,     // iris blades
    BounceLimit,      // stopped by the optional reflection limit
    EventLimit,       // stopped after kMaxPhotonEvents events (a trapped photon)
    Lost,             // no boundary found (a numerical failure; counted, never expected)
    Count
};
const char* toString(PhotonFate fate);

inline constexpr int kMaxPhotonEvents = 4096;
inline constexpr int kMaxSensorArrivals = 16;

// One arrival at the sensor (a photon may arrive several times: the sensor reflects).
struct SensorArrival {
    glm::dvec2 positionMm{0.0};  // lens space, on the sensor
    PathKey key = 0;             // reflection sequence so far
    bool scattered = false;      // met a diffuse wall on the way
};

struct PhotonHistory {
    PhotonFate fate = PhotonFate::Lost;
    bool entered = false;  // crossed the front clear aperture into the lens
    int reflections = 0;   // specular reflections, including total internal ones and the sensor's
    int scatters = 0;      // diffuse bounces off the interior
    int events = 0;        // every boundary met
    int arrivalCount = 0;
    std::array<SensorArrival, kMaxSensorArrivals> arrivals;
};

class PhotonTracer {
public:
    // maxBounces < 0: unbounded. Otherwise a photon about to make reflection maxBounces + 1 stops
    // (fate BounceLimit): the thesis compares limits of 2, 5 and 10.
    PhotonTracer(const LensSystem& lens, const InteriorMaterials& materials, int maxBounces = -1);

    // Traces one photon from object space (the ray must start in front of the first surface).
    void trace(const SpectralIndices& indices, const Ray& ray, Rng& rng, PhotonHistory& history) const;

    const LensSystem& lens() const { return *lens_; }

private:
    struct Cell {
        double wallRadiusMm = 0.0;
        bool glass = false;
    };
    struct Rim {
        double extentMm = 0.0;  // the surface exists out to this radius (the stop: the blades' reach)
        double zMm = 0.0;       // z of the surface at that radius: where the cell's annulus lies
    };

    const LensSystem* lens_;
    InteriorMaterials materials_;
    int maxBounces_;
    std::vector<Cell> cells_;  // surfaceCount + 1
    std::vector<Rim> rims_;    // surfaceCount
};

}  // namespace flare
