#include "flare/photons/PhotonTracer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <numbers>
#include <optional>

#include <glm/geometric.hpp>

#include "flare/optics/Fresnel.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/photons/MajorantGrid.h"
#include "flare/photons/Phase.h"
#include "flare/photons/VolumeGrid.h"

namespace flare {

PathKey withReflection(PathKey key, int count, int surface) {
    if (key == kLongPathKey || count >= kPathKeyMaxReflections) return kLongPathKey;
    const PathKey low = key & ((PathKey{1} << 56) - 1);
    return (static_cast<PathKey>(count + 1) << 56) | low | (static_cast<PathKey>(surface & 0xff) << (8 * count));
}

PathKey pathKey(const std::vector<int>& reflections) {
    if (reflections.size() > kPathKeyMaxReflections) return kLongPathKey;
    PathKey key = static_cast<PathKey>(reflections.size()) << 56;
    for (size_t i = 0; i < reflections.size(); ++i)
        key |= static_cast<PathKey>(reflections[i] & 0xff) << (8 * i);
    return key;
}

const char* toString(PhotonFate fate) {
    switch (fate) {
        case PhotonFate::Escaped: return "escaped";
        case PhotonFate::AbsorbedSensor: return "absorbed_sensor";
        case PhotonFate::AbsorbedHousing: return "absorbed_housing";
        case PhotonFate::AbsorbedEdge: return "absorbed_edge";
        case PhotonFate::AbsorbedIris: return "absorbed_iris";
        case PhotonFate::AbsorbedDust: return "absorbed_dust";
        case PhotonFate::AbsorbedGrease: return "absorbed_grease";
        case PhotonFate::AbsorbedBulk: return "absorbed_bulk";
        case PhotonFate::BounceLimit: return "bounce_limit";
        case PhotonFate::EventLimit: return "event_limit";
        case PhotonFate::Lost: return "lost";
        case PhotonFate::Count: break;
    }
    return "?";
}

const char* toString(ScatterSource source) {
    switch (source) {
        case ScatterSource::None: return "none";
        case ScatterSource::Housing: return "housing";
        case ScatterSource::Dust: return "dust";
        case ScatterSource::Grease: return "grease";
        case ScatterSource::Bulk: return "bulk";
        case ScatterSource::Count: break;
    }
    return "?";
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Exit distance of a ray inside the cylinder x² + y² = R² (kInf if it runs parallel to the axis).
// A ray that starts outside it (by rounding: at the seam of a surface's rim and the wall) and does
// not come in is in the wall already: it exits at t = 0.
double cylinderExit(const Ray& ray, double radiusMm) {
    const double a = ray.direction.x * ray.direction.x + ray.direction.y * ray.direction.y;
    if (a < 1e-300) return kInf;
    const double b = ray.originMm.x * ray.direction.x + ray.originMm.y * ray.direction.y;
    const double c = ray.originMm.x * ray.originMm.x + ray.originMm.y * ray.originMm.y - radiusMm * radiusMm;
    const double disc = b * b - a * c;
    if (c > 0.0 && (b >= 0.0 || disc < 0.0)) return 0.0;
    if (disc < 0.0) return kInf;  // not reached: inside, disc ≥ b² ≥ 0
    // Larger root of a t² + 2 b t + c, written without cancellation.
    const double s = std::sqrt(disc);
    return b <= 0.0 ? (s - b) / a : -c / (b + s);
}


}  // namespace

PhotonTracer::PhotonTracer(const LensSystem& lens, const InteriorMaterials& materials, int maxBounces,
                           std::vector<SurfaceContamination> contamination, std::vector<BulkMedium> media)
    : lens_(&lens), materials_(materials), maxBounces_(maxBounces), contamination_(std::move(contamination)),
      media_(std::move(media)) {
    const int n = lens.surfaceCount();
    if (!contamination_.empty() && static_cast<int>(contamination_.size()) != n)
        throw std::invalid_argument("PhotonTracer: one contamination entry per surface");
    for (const SurfaceContamination& c : contamination_) hasContamination_ = hasContamination_ || c.any();
    mediumOfCell_.assign(n + 1, -1);
    for (size_t m = 0; m < media_.size(); ++m) {
        const int cell = media_[m].cell;
        if (cell < 1 || cell >= n || lens.mediumBefore(cell).isAir() || mediumOfCell_[cell] >= 0)
            throw std::invalid_argument("PhotonTracer: a bulk medium must fill one glass element");
        mediumOfCell_[cell] = static_cast<int>(m);
        majorants_.push_back(media_[m].grid ? MajorantGrid(*media_[m].grid) : MajorantGrid());
    }
    cells_.resize(n + 1);
    rims_.resize(n);
    const auto housing = lens.housing();
    for (int g = 1; g <= n; ++g) {
        Cell& cell = cells_[g];
        cell.glass = !lens.mediumBefore(g).isAir();
        const double behind = lens.surface(g - 1).mechSemiDiameterMm;
        const double ahead = g < n ? lens.surface(g).mechSemiDiameterMm : 0.0;
        cell.wallRadiusMm = cell.glass ? std::max(behind, ahead) : housing[g - 1].innerRadiusMm;
        if (g == n) cell.wallRadiusMm = std::max(cell.wallRadiusMm, lens.sensorHalfDiagonalMm());
    }
    cells_[0].wallRadiusMm = kInf;
    for (int k = 0; k < n; ++k) {
        const Surface& s = lens.surface(k);
        Rim& rim = rims_[k];
        // The iris blades reach the barrel on both sides of the stop. An optical surface ends at its
        // clear radius: beyond it the element is ground flat (the bevel under its retaining ring)
        // out to its edge, the annulus. LensSystem::build checks that these profiles never cross.
        rim.extentMm = s.isStop ? std::max(k > 0 ? cells_[k].wallRadiusMm : 0.0, cells_[k + 1].wallRadiusMm)
                                : s.semiApertureMm;
        rim.zMm = s.vertexZMm + s.profileSagMm(rim.extentMm, rim.extentMm);  // (a conic may end before)
    }
    packetConstants_ = makePacketConstants();
}

PhotonTracer::~PhotonTracer() = default;

void PhotonTracer::tabulateReflectance() {
    if (reflectance_) return;
    auto table = std::make_shared<const SpectralReflectance>(*lens_);
    // A lens without multilayer coatings keeps the exact response everywhere: no table to consult.
    if (table->tabulatedInterfaces() > 0) reflectance_ = std::move(table);
}

std::unique_ptr<PhotonTracer::Scratch> PhotonTracer::makeScratch() const {
    auto scratch = std::make_unique<Scratch>();
    for (const BulkMedium& m : media_)
        scratch->samplers.push_back(m.grid ? std::optional<VolumeGrid::Sampler>(m.grid->sampler()) : std::nullopt);
    return scratch;
}

double PhotonTracer::scatteringPerMm(const BulkMedium& medium, double wavelengthNm) const {
    if (!medium.rayleigh) return medium.scatteringPerMm;
    const double ratio = medium.referenceWavelengthNm / wavelengthNm;
    return medium.scatteringPerMm * ratio * ratio * ratio * ratio;
}

void PhotonTracer::trace(const SpectralIndices& indices, const Ray& start, Rng& rng, PhotonHistory& h) const {
    const std::unique_ptr<Scratch> scratch = makeScratch();
    trace(indices, start, rng, h, *scratch);
}

void PhotonTracer::trace(const SpectralIndices& indices, const Ray& start, Rng& rng, PhotonHistory& h,
                         Scratch& scratch) const {
    traceFrom(indices, WalkStart{start}, rng, h, scratch);
}

void PhotonTracer::traceFrom(const SpectralIndices& indices, const WalkStart& start, Rng& rng, PhotonHistory& h,
                             Scratch& scratch) const {
    const LensSystem& lens = *lens_;
    const int n = lens.surfaceCount();
    h.restart();
    h.reflections = start.reflections;
    h.events = start.events;
    h.entered = start.entered;
    Ray ray = start.ray;
    int cell = start.cell;
    int onSurface = start.onSurface;  // the surface the photon stands on, if any
    PathKey key = start.key;
    bool scattered = false;
    ScatterSource firstScatter = ScatterSource::None;
    auto markScattered = [&](ScatterSource source) {
        if (!scattered) firstScatter = source;
        scattered = true;
        ++h.scatters;
    };

    // Appends a specular reflection at `surface` (n: the sensor); false if the limit stops it.
    auto addReflection = [&](int surface) {
        if (maxBounces_ >= 0 && h.reflections >= maxBounces_) return false;
        key = withReflection(key, h.reflections++, surface);
        return true;
    };
    // Stray light sampling (StrayLightSampling): the photon's weight while it stays above the floor.
    double& weight = h.weight;
    auto weighted = [&] { return stray_.weighted && weight >= kStrayWeightFloor; };
    auto deposit = [&](PhotonFate fate, double share) { h.deposited[static_cast<int>(fate)] += share; };

    // Branches of the walk (stray light sampling, see StrayLightSampling): where the photon met a
    // dusty or greasy surface, its state, to be resumed at the same point with the
    // contamination's outcome forced; where a bounce off the interior split, a child's state
    // (kind None: it searches for its next event like any walk).
    enum class Kind { None, Behind, Ahead, Wall, SensorPlane };
    enum class Outcome : std::uint8_t { Drawn, Met, Missed };
    struct Branch {
        Ray ray;
        int cell = 0, onSurface = -1, reflections = 0;
        PathKey key = 0;
        bool scattered = false;
        ScatterSource firstScatter = ScatterSource::None;
        double weight = 0.0;
        Kind kind = Kind::None;
        Outcome dust = Outcome::Drawn, grease = Outcome::Drawn;
    };
    std::array<Branch, kMaxStrayBranches> branches;
    int branchCount = 0;
    Kind resumeKind = Kind::None;  // a resumed contamination branch stands on its surface: no search
    Outcome dustOutcome = Outcome::Drawn, greaseOutcome = Outcome::Drawn;
    // Whether contamination met with probability `coverage` splits the walk into a branch that
    // meets it (weight × coverage) and one that does not (weight × (1 − coverage)), rather than
    // choosing one by roulette.
    auto splits = [&](double coverage) {
        return stray_.weighted && coverage < 1.0 && weight * coverage >= kStrayWeightFloor &&
               branchCount < kMaxStrayBranches;
    };
    auto pushBranch = [&](Kind kind, double coverage, Outcome dust, Outcome grease) {
        branches[branchCount++] = {ray,          cell, onSurface, h.reflections, key, scattered, firstScatter,
                                   weight * coverage, kind, dust, grease};
        weight *= 1.0 - coverage;
    };

    // A bounce off the interior: diffuse with probability `diffuse`, glossy (Phong lobe about the
    // mirror direction) with probability `glossy`, else absorbed (analog; weighted, the photon
    // always bounces and the absorbed share is deposited in `absorbed`). Weighted, the bounce may
    // also split (StrayLightSampling::scatterSplits): K directions drawn independently from the
    // lobe, each carrying 1/K of the weight; the photon goes on with the first, the others become
    // branches resumed from this point once it ends.
    auto scatterOff = [&](double diffuse, double glossy, const glm::dvec3& normalTowardsPhoton, PhotonFate absorbed,
                          bool connected = false) {
        if (diffuse <= 0.0 && glossy <= 0.0) return false;
        double u = rng.uniform();
        int children = 1;
        const glm::dvec3 mirror = glm::normalize(reflect(ray.direction, normalTowardsPhoton));
        auto draw = [&](double uLobe) {
            const double u1 = rng.uniform(), u2 = rng.uniform();
            if (uLobe < diffuse) return sampleCosineHemisphere(normalTowardsPhoton, u1, u2);
            return samplePowerCosine(mirror, materials_.glossExponent, u1, u2);
        };
        if (weighted()) {
            deposit(absorbed, weight * (1.0 - diffuse - glossy));
            weight *= diffuse + glossy;
            u *= diffuse + glossy;
            // K is decided before any direction is drawn, from the walk's state alone (the
            // weight, the room for branches), so every child's 1/K is the probability-free
            // weight of an average of K independent draws: unbiased for any K. Only the first
            // bounce splits: its children's later bounces would multiply the branches (and the
            // arrivals) geometrically for light already weighted down by the albedo.
            if (stray_.scatterSplits > 1 && !connected && !scattered)
                children = std::max(1, std::min({stray_.scatterSplits, kMaxStrayBranches - branchCount + 1,
                                                  static_cast<int>(std::min(weight / kStrayWeightFloor, 1e6))}));
            if (children > 1) {
                weight /= children;
                for (int c = 1; c < children; ++c) {
                    const glm::dvec3 w = draw(rng.uniform() * (diffuse + glossy));
                    if (glm::dot(w, normalTowardsPhoton) <= 0.0) {  // into the paint (glossy only)
                        deposit(absorbed, weight);
                        continue;
                    }
                    branches[branchCount++] = {Ray{ray.originMm, w}, cell, onSurface, h.reflections, key, true,
                                               scattered ? firstScatter : ScatterSource::Housing,
                                               weight * stray_.testSplitScale, Kind::None,
                                               Outcome::Drawn, Outcome::Drawn};
                }
            }
        } else if (u >= diffuse + glossy) {
            return false;
        }
        ray.direction = draw(u);
        if (glm::dot(ray.direction, normalTowardsPhoton) <= 0.0) return false;  // into the paint (glossy only)
        markScattered(ScatterSource::Housing);
        return true;
    };

    // Next-event estimation in the sensor's cell (StrayLightSampling::connectSensor): before a
    // bounce off its walls, a point drawn uniformly on the sensor is connected to the bounce. The
    // bounce's direct hit, if its next event is the sensor, is weighted against it (power
    // heuristic over the two strategies' densities per steradian).
    const SensorSpec& sensor = lens.sensor();
    const double sensorAreaMm2 = sensor.widthMm * sensor.heightMm;
    struct Connection {
        int event = -1;  // h.events of the bounce
        glm::dvec3 pointMm{0.0}, normal{0.0}, mirror{0.0};
        double diffuse = 0.0, glossy = 0.0, lobeShare = 1.0;  // lobeShare: d + g when weighted
        double lobePdf(const glm::dvec3& w, double exponent) const {
            return paintLobeDensity(normal, mirror, diffuse, glossy, exponent, w) / lobeShare;
        }
    } connection;
    // False when the photon has no room for another arrival (it then stops: EventLimit).
    auto connectToSensor = [&](const glm::dvec3& x, const glm::dvec3& normalTowardsPhoton, double diffuse,
                               double glossy) {
        connection = {h.events,   x,       normalTowardsPhoton, glm::normalize(reflect(ray.direction, normalTowardsPhoton)),
                      diffuse,    glossy,  weighted() ? diffuse + glossy : 1.0};
        const double u1 = rng.uniform(), u2 = rng.uniform();
        const glm::dvec3 y((u1 - 0.5) * sensor.widthMm, (u2 - 0.5) * sensor.heightMm, lens.sensorZMm());
        const double distance2 = glm::dot(y - x, y - x);
        if (!(distance2 > 0.0)) return true;
        const glm::dvec3 w = (y - x) / std::sqrt(distance2);
        const double lobe = paintLobeDensity(normalTowardsPhoton, connection.mirror, diffuse, glossy,
                                             materials_.glossExponent, w);
        if (!(lobe > 0.0) || !(w.z > 0.0)) return true;
        // Hidden if the last surface (or its bevel) lies in between; the wall is convex and the
        // annulus and the body around the sensor face the other way.
        const Surface& last = lens.surface(n - 1);
        const Rim& rim = rims_[n - 1];
        double tMin = kLeaveSurfaceMm;
        for (int crossing = 0; crossing < 3; ++crossing) {
            const SurfaceHit hit = intersect(last, Ray{x, w}, tMin);
            if (hit.status != HitStatus::Hit || hit.tMm * hit.tMm >= distance2) break;
            const glm::dvec3 p = x + hit.tMm * w;
            if (p.x * p.x + p.y * p.y <= rim.extentMm * rim.extentMm * (1.0 + kSeamTolerance)) return true;
            tMin = hit.tMm + kLeaveSurfaceMm;
        }
        if (h.arrivalCount == kMaxSensorArrivals) return false;
        const double sensorPdf = flatAreaDirectionPdf(x, y, sensorAreaMm2);
        const double lobePdf = lobe / connection.lobeShare;
        const double mis = sensorPdf * sensorPdf / (sensorPdf * sensorPdf + lobePdf * lobePdf);
        h.arrivals[h.arrivalCount++] = {{y.x, y.y},
                                        weight * lobe / sensorPdf * mis * stray_.testConnectionScale,
                                        key,
                                        true,
                                        scattered ? firstScatter : ScatterSource::Housing};
        return true;
    };
    const bool connectSensor = stray_.connectSensor && !cells_[n].glass && mediumOfCell_[n] < 0 && sensorAreaMm2 > 0.0;

    auto walk = [&] {
        while (h.events < kMaxPhotonEvents) {
            Kind kind = Kind::None;
            double best = kInf;
            glm::dvec3 wallNormal(0.0);

            if (resumeKind != Kind::None) {
                kind = resumeKind, best = 0.0;
                resumeKind = Kind::None;
            } else {
                auto trySurface = [&](int k, Kind which) {
                    // A ray near the wall can cross the surface's continuation beyond its rim (where the
                    // surface does not exist) before crossing the surface itself: look past such hits.
                    const Surface& surface = lens.surface(k);
                    double tMin = k == onSurface ? kLeaveSurfaceMm : -kOnBoundaryMm;
                    for (int crossing = 0; crossing < 3; ++crossing) {
                        const SurfaceHit hit = intersect(surface, ray, tMin);
                        if (hit.status != HitStatus::Hit || hit.tMm >= best) return;
                        const glm::dvec3 p = ray.at(hit.tMm);
                        // A hit where the photon stands (kOnBoundaryMm) counts only if it leaves the cell:
                        // forwards through the surface ahead, backwards through the one behind.
                        const bool leaves = hit.tMm >= kOnBoundaryMm ||
                                            (glm::dot(surface.normalAt(p), ray.direction) > 0.0) == (which == Kind::Ahead);
                        if (leaves && p.x * p.x + p.y * p.y <= rims_[k].extentMm * rims_[k].extentMm * (1.0 + kSeamTolerance)) {
                            best = std::max(hit.tMm, 0.0);
                            kind = which;
                            return;
                        }
                        tMin = hit.tMm + kLeaveSurfaceMm;
                    }
                };
                if (cell > 0) trySurface(cell - 1, Kind::Behind);
                if (cell < n) trySurface(cell, Kind::Ahead);
                if (cell == n && ray.direction.z > 0.0) {
                    const double t = (lens.sensorZMm() - ray.originMm.z) / ray.direction.z;
                    if (t >= -kOnBoundaryMm && t < best) best = std::max(t, 0.0), kind = Kind::SensorPlane;
                }
                if (cell > 0) {
                    const double wall = cells_[cell].wallRadiusMm;
                    const double tCylinder = cylinderExit(ray, wall);
                    if (tCylinder < best) {
                        best = tCylinder, kind = Kind::Wall;
                        const glm::dvec3 p = ray.at(tCylinder);
                        wallNormal = glm::normalize(glm::dvec3(-p.x, -p.y, 0.0));
                    }
                    // Annuli between a surface's rim and the wall, at the rim's z.
                    auto tryAnnulus = [&](int k, double facing) {
                        if (ray.direction.z * facing >= 0.0) return;  // moving away from it
                        const double t = (rims_[k].zMm - ray.originMm.z) / ray.direction.z;
                        if (t < -kOnBoundaryMm || t >= best) return;
                        const glm::dvec3 p = ray.at(t);
                        const double r2 = p.x * p.x + p.y * p.y;
                        if (r2 < rims_[k].extentMm * rims_[k].extentMm * (1.0 - kSeamTolerance) ||
                            r2 > wall * wall * (1.0 + kSeamTolerance))
                            return;
                        best = std::max(t, 0.0), kind = Kind::Wall;
                        wallNormal = glm::dvec3(0.0, 0.0, facing);
                    };
                    tryAnnulus(cell - 1, 1.0);            // behind the photon, facing +z
                    if (cell < n) tryAnnulus(cell, -1.0);  // ahead, facing −z
                }

                if (kind == Kind::None) {
                    h.fate = cell == 0 ? PhotonFate::Escaped : PhotonFate::Lost;
                    return;
                }
                if (const int m = mediumOfCell_[cell]; m >= 0) {
                    // Delta tracking to the boundary: through the grid's coarse majorants (MajorantGrid),
                    // or exactly in a homogeneous medium, where σt itself is the rate.
                    const BulkMedium& medium = media_[m];
                    const double sigmaS = scatteringPerMm(medium, indices.wavelengthNm);
                    const double sigmaT = sigmaS + medium.absorptionPerMm;
                    const glm::dvec3 frontVertex(0.0, 0.0, lens.surface(cell - 1).vertexZMm);
                    const double t = medium.grid ? sampleFreeFlight(majorants_[m], *scratch.samplers[m], sigmaT,
                                                                    ray.originMm - frontVertex, ray.direction, best, rng,
                                                                    h.nullCollisions)
                                     : sigmaT > 0.0 ? -std::log(1.0 - rng.uniform()) / sigmaT
                                                    : kInf;
                    if (t < best) {
                        ++h.realCollisions;
                        ++h.events;
                        ray.originMm = ray.at(t);
                        onSurface = -1;
                        if (rng.uniform() * sigmaT >= sigmaS) {
                            h.fate = PhotonFate::AbsorbedBulk;
                            return;
                        }
                        const double u1 = rng.uniform(), u2 = rng.uniform();
                        ray.direction = sampleHenyeyGreenstein(ray.direction, medium.g, u1, u2);
                        markScattered(ScatterSource::Bulk);
                        continue;
                    }
                }
            }
            ++h.events;
            const glm::dvec3 p = ray.at(best);
            ray.originMm = p;
            onSurface = -1;

            if (kind == Kind::Wall) {
                const bool edge = cells_[cell].glass;
                const double diffuse = edge ? materials_.edgeAlbedo : materials_.housingAlbedo;
                const double glossy = edge ? materials_.edgeGlossy : materials_.housingGlossy;
                const PhotonFate absorbed = edge ? PhotonFate::AbsorbedEdge : PhotonFate::AbsorbedHousing;
                if (connectSensor && cell == n && diffuse + glossy > 0.0 && !connectToSensor(p, wallNormal, diffuse, glossy)) {
                    h.fate = PhotonFate::EventLimit;
                    return;
                }
                // (A bounce connected to the sensor does not split: its branches would lose the
                // connection that their direct hits' MIS weights assume.)
                if (!scatterOff(diffuse, glossy, wallNormal, absorbed, connection.event == h.events)) {
                    h.fate = absorbed;
                    return;
                }
                continue;
            }

            if (kind == Kind::SensorPlane) {
                const bool onSensor = std::abs(p.x) <= 0.5 * lens.sensor().widthMm && std::abs(p.y) <= 0.5 * lens.sensor().heightMm;
                if (!onSensor) {  // the camera body around the sensor
                    if (!scatterOff(materials_.housingAlbedo, materials_.housingGlossy, {0.0, 0.0, -1.0},
                                    PhotonFate::AbsorbedHousing)) {
                        h.fate = PhotonFate::AbsorbedHousing;
                        return;
                    }
                    continue;
                }
                if (h.arrivalCount == kMaxSensorArrivals) {
                    h.fate = PhotonFate::EventLimit;
                    return;
                }
                double mis = 1.0;
                if (connection.event == h.events - 1) {  // straight from a bounce that was connected
                    const double sensorPdf = flatAreaDirectionPdf(connection.pointMm, p, sensorAreaMm2);
                    const double lobePdf = connection.lobePdf(ray.direction, materials_.glossExponent);
                    mis = lobePdf * lobePdf / (lobePdf * lobePdf + sensorPdf * sensorPdf);
                }
                h.arrivals[h.arrivalCount++] = {{p.x, p.y}, weight * mis, key, scattered, firstScatter};
                if (weighted() && sensor.reflectance > 0.0) {
                    deposit(PhotonFate::AbsorbedSensor, weight * (1.0 - sensor.reflectance));
                    weight *= sensor.reflectance;
                } else if (rng.uniform() >= sensor.reflectance) {
                    h.fate = PhotonFate::AbsorbedSensor;
                    return;
                }
                if (!addReflection(n)) {
                    h.fate = PhotonFate::BounceLimit;
                    return;
                }
                ray.direction.z = -ray.direction.z;  // specular off the sensor's cover
                continue;
            }

            const bool forward = kind == Kind::Ahead;
            const int k = forward ? cell : cell - 1;
            const int other = forward ? cell + 1 : cell - 1;
            const Surface& surface = lens.surface(k);
            onSurface = k;
            const glm::dvec3 towardsPhoton(0.0, 0.0, forward ? -1.0 : 1.0);

            if (surface.isStop) {
                if (lens.iris().contains(p.x, p.y)) {
                    cell = other;
                    continue;
                }
                if (!scatterOff(materials_.irisAlbedo, materials_.irisGlossy, towardsPhoton, PhotonFate::AbsorbedIris)) {
                    h.fate = PhotonFate::AbsorbedIris;
                    return;
                }
                continue;
            }
            if (p.x * p.x + p.y * p.y > surface.semiApertureMm * surface.semiApertureMm) {
                // Outside the clear aperture (within the seam tolerance of the rim): the retaining ring.
                glm::dvec3 normal = surface.normalAt(p);
                if (glm::dot(normal, ray.direction) > 0.0) normal = -normal;
                if (!scatterOff(materials_.housingAlbedo, materials_.housingGlossy, normal, PhotonFate::AbsorbedHousing)) {
                    h.fate = PhotonFate::AbsorbedHousing;
                    return;
                }
                continue;
            }

            const double n1 = indices.n[cell], n2 = indices.n[other];
            if (n1 == n2) {  // a surface between equal media does not act on the light
                if (k == 0 && forward) h.entered = true;
                cell = other;
                continue;
            }
            glm::dvec3 normal = surface.normalAt(p);
            glm::dvec3 roughTowards(0.0);  // set when a grease facet replaces the surface normal
            if (hasContamination_ && contamination_[k].any()) {
                const SurfaceContamination& c = contamination_[k];
                // Whether the photon meets contamination of local coverage here: forced on a
                // resumed branch (`outcome`), else split into two branches by stray light sampling
                // (the one that meets it resumes with `branchDust`, `branchGrease`), else drawn.
                // Zero local coverage draws no random number: a clean patch traces as a clean lens.
                auto meets = [&](double coverage, Outcome& outcome, Outcome branchDust, Outcome branchGrease) {
                    bool met = outcome == Outcome::Met;
                    if (outcome == Outcome::Drawn && coverage > 0.0) {
                        if (splits(coverage))
                            pushBranch(kind, coverage, branchDust, branchGrease);
                        else
                            met = rng.uniform() < coverage;
                    }
                    outcome = Outcome::Drawn;
                    return met;
                };
                if (meets(c.dustCoverageAt(p.x, p.y), dustOutcome, Outcome::Met, Outcome::Drawn)) {
                    if (weighted()) {
                        deposit(PhotonFate::AbsorbedDust, weight * (1.0 - c.dustAlbedo));
                        weight *= c.dustAlbedo;
                    } else if (rng.uniform() >= c.dustAlbedo) {
                        h.fate = PhotonFate::AbsorbedDust;
                        return;
                    }
                    const double u1 = rng.uniform(), u2 = rng.uniform(), u3 = rng.uniform(), u4 = rng.uniform();
                    if (u1 < 0.5) {
                        // Diffraction by a particle of diameter d: a forward lobe ~0.42 λ/d wide
                        // (the Gaussian fit of the Airy core), d log-normal about the median.
                        const double gauss = std::sqrt(-2.0 * std::log(1.0 - u2)) * std::cos(2.0 * std::numbers::pi * u3);
                        const double diameterNm = 1e3 * c.dustDiameterUm * std::exp(c.dustDiameterSigma * gauss);
                        const double sigmaRad = 0.42 * indices.wavelengthNm / diameterNm;
                        const double theta = std::min(sigmaRad * std::sqrt(-2.0 * std::log(1.0 - u4)), std::numbers::pi);
                        ray.direction = directionAround(ray.direction, std::cos(theta), 2.0 * std::numbers::pi * rng.uniform());
                    } else {
                        ray.direction = sampleHenyeyGreenstein(ray.direction, 0.6, u2, u3);
                    }
                    markScattered(ScatterSource::Dust);
                    // The particle sits on the surface: the scattered light meets the interface now
                    // if it still heads into it, else it leaves back into this cell.
                    if ((glm::dot(normal, ray.direction) > 0.0) != forward) {
                        greaseOutcome = Outcome::Drawn;
                        continue;
                    }
                }
                if (meets(c.greaseCoverageAt(p.x, p.y), greaseOutcome, Outcome::Missed, Outcome::Met)) {
                    // A rough patch: the photon meets a GGX microfacet instead of the smooth surface.
                    // Facets seen from behind (steep facets at grazing light) are left out: the
                    // photon then meets the smooth surface, a small bias towards the smooth surface.
                    const glm::dvec3 towards = glm::dot(normal, ray.direction) < 0.0 ? normal : -normal;
                    const double u1 = rng.uniform(), u2 = rng.uniform();
                    const glm::dvec3 facet = sampleGgxNormal(towards, c.greaseRoughness, u1, u2);
                    if (glm::dot(facet, ray.direction) < 0.0) {
                        normal = facet;
                        roughTowards = towards;
                        markScattered(ScatterSource::Grease);
                    }
                }
            }
            const double cosThetaI = std::min(1.0, std::abs(glm::dot(normal, ray.direction)));
            glm::dvec3 refracted;
            if (reflects(indices, k, forward ? 1 : -1, cosThetaI, rng.uniform()) ||
                !refract(ray.direction, normal, n1, n2, &refracted)) {
                if (!addReflection(k)) {
                    h.fate = PhotonFate::BounceLimit;
                    return;
                }
                ray.direction = glm::normalize(reflect(ray.direction, normal));
                if (glm::dot(ray.direction, roughTowards) < 0.0) {  // a facet sent it into the surface
                    h.fate = PhotonFate::AbsorbedGrease;
                    return;
                }
                continue;
            }
            if (glm::dot(refracted, roughTowards) > 0.0) {  // refracted back out of the facet's surface
                h.fate = PhotonFate::AbsorbedGrease;
                return;
            }
            ray.direction = refracted;
            if (k == 0 && forward) h.entered = true;
            cell = other;
        }
        h.fate = PhotonFate::EventLimit;
    };

    walk();
    // Each branch ends in a fate of its own: all but the last are deposited there.
    while (branchCount > 0) {
        h.deposited[static_cast<int>(h.fate)] += weight;
        const Branch& b = branches[--branchCount];
        ray = b.ray, cell = b.cell, onSurface = b.onSurface, h.reflections = b.reflections, key = b.key;
        scattered = b.scattered, firstScatter = b.firstScatter, weight = b.weight;
        resumeKind = b.kind, dustOutcome = b.dust, greaseOutcome = b.grease;
        connection.event = -1;
        walk();
    }
}

bool PhotonTracer::reflects(const SpectralIndices& indices, int k, int direction, double cosThetaI, double u) const {
    // Most draws lie above a single-layer coating's bound (it reflects a few per cent): they
    // refract without the film's phase. The rest compare with the response itself.
    if (u >= interfaceReflectanceBound(*lens_, indices, k, direction, cosThetaI)) return false;
    if (reflectance_) return u < reflectance_->reflectance(k, direction, indices.wavelengthNm, indices, cosThetaI);
    const FresnelTerms response = interfaceResponse(*lens_, indices, k, direction, cosThetaI);
    return u < (response.totalInternalReflection ? 1.0 : response.reflectance());
}

double PhotonTracer::clearTransmittance(const std::vector<glm::dvec3>& points, const std::vector<int>& surfaces,
                                       double wavelengthNm, Rng& rng, Scratch& scratch) const {
    const int n = lens_->surfaceCount();
    double transmittance = 1.0;
    for (size_t i = 0; i < surfaces.size(); ++i) {
        const int k = surfaces[i];
        if (hasContamination_ && k >= 0 && k < n && !lens_->surface(k).isStop) {
            const SurfaceContamination& c = contamination_[k];
            const glm::dvec3& p = points[i];
            transmittance *= (1.0 - c.dustCoverageAt(p.x, p.y)) * (1.0 - c.greaseCoverageAt(p.x, p.y));
        }
        if (media_.empty() || i == 0) continue;
        // The segment from the previous event lies in the cell between the two surfaces.
        const int cell = std::max(surfaces[i - 1], k);
        const int m = cell >= 0 && cell <= n ? mediumOfCell_[cell] : -1;
        if (m < 0) continue;
        // Ratio tracking through the grid's coarse majorants; a homogeneous medium's transmittance
        // is known exactly.
        const BulkMedium& medium = media_[m];
        const double sigmaT = scatteringPerMm(medium, wavelengthNm) + medium.absorptionPerMm;
        const glm::dvec3 from = points[i - 1], to = points[i];
        const double length = glm::length(to - from);
        if (!medium.grid) {
            transmittance *= std::exp(-sigmaT * length);
            continue;
        }
        if (!(length > 0.0)) continue;
        const glm::dvec3 frontVertex(0.0, 0.0, lens_->surface(cell - 1).vertexZMm);
        transmittance *= ratioTrackingTransmittance(majorants_[m], *scratch.samplers[m], sigmaT, from - frontVertex,
                                                    (to - from) / length, length, rng);
    }
    return transmittance;
}

}  // namespace flare
