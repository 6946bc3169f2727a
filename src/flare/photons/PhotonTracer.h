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
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <glm/vec2.hpp>

#include "flare/core/Random.h"
#include "flare/core/Ray.h"
#include "flare/optics/LensSystem.h"
#include "flare/optics/SpectralReflectance.h"
#include "flare/photons/CoverageMask.h"
#include "flare/photons/MajorantGrid.h"
#include "flare/photons/VolumeGrid.h"

namespace flare {

namespace detail {
struct PhotonSearchConstants;  // PhotonPacket.cpp
}

// How the lens's inner parts reflect: a Lambertian part (albedo) plus a glossy Phong lobe about the
// mirror direction (its share and exponent); the rest is absorbed. 0, 0 is perfectly black. A
// photon that scatters off one of them is marked scattered and lands in the `scatter` layer.
struct InteriorMaterials {
    double housingAlbedo = 0.0;  // barrel walls, retaining rings, the camera body around the sensor
    double edgeAlbedo = 0.0;     // ground element edges (inside the glass)
    double irisAlbedo = 0.0;     // iris blades
    double housingGlossy = 0.0, edgeGlossy = 0.0, irisGlossy = 0.0;
    double glossExponent = 30.0;
};

// Contamination of one surface (both default off). Dust: a share `dustCoverage` of the surface is
// covered by particles, so light crossing or reflecting there meets one with that probability; a
// particle scatters the share dustAlbedo (half by diffraction into a narrow forward lobe of angular
// width ~0.42 λ/d for its diameter d, drawn log-normally about dustDiameterUm; half by refraction
// and reflection into a broad Henyey–Greenstein lobe, g = 0.6) and absorbs the rest. Grease: on a
// share `greaseCoverage` of the surface the interface is rough, a GGX microfacet surface of
// roughness greaseRoughness whose facets reflect and refract with the Fresnel/coating factors.
// A mask (CoverageMask, placed in the surface's x, y) makes either coverage local: coverage ×
// the mask's value where the light meets the surface.
struct SurfaceContamination {
    double dustCoverage = 0.0;
    double dustAlbedo = 0.5;
    double dustDiameterUm = 20.0;
    double dustDiameterSigma = 0.5;  // of ln(diameter)
    double greaseCoverage = 0.0;
    double greaseRoughness = 0.1;
    std::shared_ptr<const CoverageMask> dustMask, greaseMask;  // null: the same coverage everywhere

    double dustCoverageAt(double xMm, double yMm) const {
        return dustMask ? dustCoverage * dustMask->valueAt(xMm, yMm) : dustCoverage;
    }
    double greaseCoverageAt(double xMm, double yMm) const {
        return greaseMask ? greaseCoverage * greaseMask->valueAt(xMm, yMm) : greaseCoverage;
    }
    // Whether any point of the surface is contaminated (an all-black mask contaminates none).
    bool any() const {
        return (dustCoverage > 0.0 && !(dustMask && dustMask->allZero())) ||
               (greaseCoverage > 0.0 && !(greaseMask && greaseMask->allZero()));
    }
};

// Bulk scattering inside one glass element: scattering and absorption coefficients (per mm) times
// a relative density, 1 everywhere (homogeneous) or from an OpenVDB grid placed in the element's
// frame (millimetres, x and y as in the lens, z from the element's front vertex).
struct BulkMedium {
    int cell = -1;                    // the element: cell g lies between surfaces g − 1 and g
    double scatteringPerMm = 0.0;     // σs at referenceWavelengthNm
    bool rayleigh = false;            // σs ∝ λ⁻⁴ (scatterers much smaller than the wavelength)
    double referenceWavelengthNm = 550.0;
    double absorptionPerMm = 0.0;     // σa (not wavelength dependent)
    double g = 0.0;                   // Henyey–Greenstein mean cosine
    std::shared_ptr<const VolumeGrid> grid;  // null: homogeneous
};

// What a scattered photon met first, for the report's split of the `scatter` layer.
enum class ScatterSource : std::uint8_t { None, Housing, Dust, Grease, Bulk, Count };
const char* toString(ScatterSource source);

// Reflection sequence of a path as one integer: the count in the top byte and up to 7 surface
// indices (0-based; surfaceCount = the sensor) one byte each. Longer sequences share kLongPathKey.
using PathKey = std::uint64_t;
inline constexpr int kPathKeyMaxReflections = 7;
inline constexpr PathKey kLongPathKey = ~PathKey{0};
PathKey pathKey(const std::vector<int>& reflections);
// The key after one more reflection, at `surface`, of a path that has made `count` so far.
PathKey withReflection(PathKey key, int count, int surface);

// The photon tracer's tolerances (trace() and its packets):
// A photon that has just left a surface starts on it up to rounding (~1e-14 mm, more at grazing
// incidence): the surface it stands on is not met again within kLeaveSurfaceMm.
inline constexpr double kLeaveSurfaceMm = 1e-6;
// Every other boundary may lie right where the photon stands: the next surface where two vertices
// coincide (a zero-thickness cell), or a wall or annulus at the seam where a surface's rim meets
// it. A boundary within this distance of the photon (ahead of it or, through rounding, behind it)
// is met at once (at t = 0) if the photon moves through it out of its cell, and ignored otherwise.
inline constexpr double kOnBoundaryMm = 1e-9;
// Where two boundaries of a cell meet (a surface's rim and its annulus, an annulus and the wall),
// both accept points within this relative tolerance of the seam, so that rounding cannot let a
// photon slip between them and out of the cell.
inline constexpr double kSeamTolerance = 1e-9;

enum class PhotonFate : std::uint8_t {
    Escaped,          // left through the front (or never entered the lens)
    AbsorbedSensor,   // absorbed by the sensor (after being counted there)
    AbsorbedHousing,  // barrel, rings, camera body
    AbsorbedEdge,     // ground element edge
    AbsorbedIris,     // iris blades
    AbsorbedDust,     // by a dust particle
    AbsorbedGrease,   // sent by a grease microfacet into the surface it sits on
    AbsorbedBulk,     // inside the glass (a bulk medium's absorption)
    BounceLimit,      // stopped by the optional reflection limit
    EventLimit,       // stopped after kMaxPhotonEvents events (a trapped photon)
    Lost,             // no boundary found (a numerical failure; counted, never expected)
    Count
};
const char* toString(PhotonFate fate);

inline constexpr int kMaxPhotonEvents = 4096;
inline constexpr int kMaxSensorArrivals = 64;  // (a split photon's children share them)

// One arrival at the sensor (a photon may arrive several times: the sensor reflects). With stray
// light sampling on, an arrival may also be a connection from a scattering point to the sensor.
struct SensorArrival {
    glm::dvec2 positionMm{0.0};  // lens space, on the sensor
    double weight = 1.0;         // share of the photon's emitted power it carries (analog: 1)
    PathKey key = 0;             // reflection sequence so far
    bool scattered = false;      // met a wall, dust, grease or the bulk on the way
    ScatterSource firstScatter = ScatterSource::None;
};

struct PhotonHistory {
    PhotonFate fate = PhotonFate::Lost;
    bool entered = false;  // crossed the front clear aperture into the lens
    int reflections = 0;   // specular reflections, including total internal ones and the sensor's
    int scatters = 0;      // diffuse bounces off the interior
    int events = 0;        // every boundary met
    int nullCollisions = 0, realCollisions = 0;  // delta tracking in bulk media
    int arrivalCount = 0;
    std::array<SensorArrival, kMaxSensorArrivals> arrivals;
    // Where the photon's power went, as shares of what it was emitted with: `weight` ends in
    // `fate`, `deposited[f]` was absorbed on the way (only stray light sampling deposits; an analog
    // photon keeps weight 1 to its fate). The shares sum to 1.
    double weight = 1.0;
    std::array<double, static_cast<int>(PhotonFate::Count)> deposited{};

    // As assigning PhotonHistory{}, except that the arrivals' storage (2.6 KB, past arrivalCount
    // never read) is left as it is: a photon's walk starts with this.
    // (Every other member is reset here: add a new one here too; a test compares with PhotonHistory{}.)
    void restart() {
        fate = PhotonFate::Lost;
        entered = false;
        reflections = scatters = events = nullCollisions = realCollisions = arrivalCount = 0;
        weight = 1.0;
        deposited = {};
    }
};

// How the tracer samples light that scatters inside the lens (stray light). Off, the walk is
// analog and is the reference the tests compare against. On:
//  - A scattering finish (housing, edges, iris) and the sensor's reflection no longer absorb by
//    roulette: the photon always goes on, its weight times the albedo or the reflectance, the
//    rest deposited in the absorbing fate. Stray light in a coated lens is mostly such chains
//    (the default scene's: the sensor reflects 2 %, the black paint scatters 3 %, and its
//    scattered arrivals were all sensor → paint → sensor), so 1 / (0.02 × 0.03) more of them
//    arrive, each lighter. Below kStrayWeightFloor the walk turns analog again: a long chain's
//    cost stays bounded, and every photon still ends in one fate with its weight.
//  - Next-event estimation in the sensor's cell: at each scattering hit on the walls between the
//    last surface and the sensor, a point drawn uniformly on the sensor is connected to it (if
//    the last surface does not hide it), and the scattered photon's own direct hit is weighted by
//    multiple importance sampling (power heuristic) against that connection.
//  - With weights on, dust and grease no longer choose by roulette whether the photon meets them:
//    the walk splits into a branch that meets them (weight × coverage), traced after the photon
//    ends, and one that does not (weight × (1 − coverage)), so every photon crossing a dusty or
//    greasy patch carries some of its scattered light (at most kMaxStrayBranches pending; the
//    dust's albedo is a weight too). Each branch ends in its own fate.
//  - Splitting at the interior finishes (scatterSplits K > 1, weighted walks only): a photon's
//    first bounce off the barrel, an edge, a ring or the iris draws K directions from its lobe,
//    each carrying 1/K of the weight, while each child stays above kStrayWeightFloor and branches
//    are free (a bounce connected to the sensor does not split). The light scattered inside the lens reaches the
//    sensor through a few directions of a bounce's lobe, so its variance is mostly the
//    direction's; the K children share the path that led to the bounce.
struct StrayLightSampling {
    bool weighted = false;
    bool connectSensor = false;
    int scatterSplits = 1;
    double testConnectionScale = 1.0;  // a test's deliberate error (multiplies the connections)
    double testSplitScale = 1.0;       // a test's deliberate error (multiplies the split-off branches' weights)
};
inline constexpr double kStrayWeightFloor = 1e-3;
inline constexpr int kMaxStrayBranches = 16;

class PhotonTracer {
public:
    // maxBounces < 0: unbounded. Otherwise a photon about to make reflection maxBounces + 1 stops
    // (fate BounceLimit): the thesis compares limits of 2, 5 and 10. `contamination` is per
    // surface (empty: clean lens); `media` at most one per glass cell.
    PhotonTracer(const LensSystem& lens, const InteriorMaterials& materials, int maxBounces = -1,
                 std::vector<SurfaceContamination> contamination = {}, std::vector<BulkMedium> media = {});
    ~PhotonTracer();

    // Per-thread state for density lookups in grids: make one per batch of photons.
    struct Scratch {
        std::vector<std::optional<VolumeGrid::Sampler>> samplers;  // per medium with a grid
    };
    std::unique_ptr<Scratch> makeScratch() const;

    // Traces one photon from object space (the ray must start in front of the first surface).
    void trace(const SpectralIndices& indices, const Ray& ray, Rng& rng, PhotonHistory& history, Scratch& scratch) const;
    void trace(const SpectralIndices& indices, const Ray& ray, Rng& rng, PhotonHistory& history) const;

    // A photon for tracePacket: its ray in object space, its indices (which must outlive the
    // call) and a generator of its own.
    struct PacketPhoton {
        Ray ray;
        const SpectralIndices* indices = nullptr;
        Rng rng;
    };
    // Traces photons[i] into histories[i] exactly as trace(*indices, ray, rng, history, scratch)
    // would, to the last bit, each drawing from its own generator (which is left where trace would
    // leave it). The stretches of the walks between interfaces are traced together in SIMD lanes
    // (PhotonPacket.cpp): the search for the next boundary, and the reflection or refraction at
    // a clean sphere or plane; at any other event (a wall, a retaining ring, the sensor, dust,
    // grease, a bulk medium, blades that scatter, a seam, a bounce limit) the photon leaves the
    // lanes and trace()'s own loop goes on from there.
    // Returns how many events the lanes traced (the rest of the histories' events were trace()'s).
    std::int64_t tracePacket(std::span<PacketPhoton> photons, std::span<PhotonHistory> histories,
                             Scratch& scratch) const;

    // Probability that light following a sequential path meets no dust, grease or bulk event: the
    // guided strategy's weight for owning only unscattered paths. `points` and `surfaces` are
    // TraceOptions' record of the path (surface index per point, −1 the start, surfaceCount the
    // sensor). Bulk transmittance is exact in a homogeneous medium and estimated without bias by
    // ratio tracking through a grid's majorants (uses rng).
    double clearTransmittance(const std::vector<glm::dvec3>& points, const std::vector<int>& surfaces,
                              double wavelengthNm, Rng& rng, Scratch& scratch) const;

    // From here on, the reflect-or-refract choice at multilayer-coated interfaces takes its
    // probability from a SpectralReflectance table instead of the exact thin-film response
    // (faster there; within 4e-4 relative, measured in its tests). Renders use it; off by default.
    // A lens without multilayer coatings keeps the exact response (tabulatesReflectance false).
    void tabulateReflectance();
    bool tabulatesReflectance() const { return reflectance_ != nullptr; }

    void setStrayLightSampling(const StrayLightSampling& sampling) { stray_ = sampling; }
    const StrayLightSampling& strayLightSampling() const { return stray_; }

    bool hasContamination() const { return hasContamination_; }
    bool hasMedia() const { return !media_.empty(); }
    const LensSystem& lens() const { return *lens_; }

private:
    // Where a walk stands between two events: what trace()'s loop needs to go on (the packets
    // hand a photon over with it). A new photon stands in object space, on no surface.
    struct WalkStart {
        Ray ray;
        int cell = 0, onSurface = -1, reflections = 0, events = 0;
        PathKey key = 0;
        bool entered = false;
    };
    void traceFrom(const SpectralIndices& indices, const WalkStart& start, Rng& rng, PhotonHistory& history,
                   Scratch& scratch) const;
    // The packets' per-surface and per-cell constants, made once with the tracer (PhotonPacket.cpp).
    std::shared_ptr<const detail::PhotonSearchConstants> makePacketConstants() const;
    std::shared_ptr<const detail::PhotonSearchConstants> packetConstants_;
    // Whether a photon meeting surface k (direction +1 towards the sensor) at incidence cosine
    // cosThetaI reflects, for its uniform draw u: u < the reflectance (the table's, or the exact
    // response; 1 under total internal reflection).
    bool reflects(const SpectralIndices& indices, int k, int direction, double cosThetaI, double u) const;
    struct Cell {
        double wallRadiusMm = 0.0;
        bool glass = false;
    };
    struct Rim {
        double extentMm = 0.0;  // the surface's clear radius (the stop: the blades' reach)
        double zMm = 0.0;       // z of the surface at that radius: where the cell's annulus lies
    };

    double scatteringPerMm(const BulkMedium& medium, double wavelengthNm) const;

    const LensSystem* lens_;
    InteriorMaterials materials_;
    int maxBounces_;
    std::vector<SurfaceContamination> contamination_;  // per surface (or empty)
    bool hasContamination_ = false;
    std::vector<BulkMedium> media_;
    std::vector<MajorantGrid> majorants_;  // per medium (empty for a homogeneous one)
    std::vector<int> mediumOfCell_;  // index into media_ or −1, per cell
    std::vector<Cell> cells_;  // surfaceCount + 1
    std::vector<Rim> rims_;    // surfaceCount
    std::shared_ptr<const SpectralReflectance> reflectance_;  // or null: the exact response
    StrayLightSampling stray_;
};

}  // namespace flare
