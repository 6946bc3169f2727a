#include "flare/PhotonTracer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <glm/geometric.hpp>

#include "flare/Fresnel.h"
#include "flare/SequentialTracer.h"

namespace flare {

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
        case PhotonFate::BounceLimit: return "bounce_limit";
        case PhotonFate::EventLimit: return "event_limit";
        case PhotonFate::Lost: return "lost";
        case PhotonFate::Count: break;
    }
    return "?";
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Smallest distance to the next boundary. A photon that has just left a surface starts on it up
// to rounding (~1e-14 mm, more at grazing incidence): the surface it stands on must not be met
// again within this distance.
constexpr double kMinStepMm = 1e-9;
constexpr double kLeaveSurfaceMm = 1e-6;
// Where two boundaries of a cell meet (a surface's rim and its annulus, an annulus and the wall),
// both accept points within this relative tolerance of the seam, so that rounding cannot let a
// photon slip between them and out of the cell.
constexpr double kSeamTolerance = 1e-9;

// Exit distance of a ray inside the cylinder x² + y² = R² (kInf if it runs parallel to the axis).
double cylinderExit(const Ray& ray, double radiusMm) {
    const double a = ray.direction.x * ray.direction.x + ray.direction.y * ray.direction.y;
    if (a < 1e-300) return kInf;
    const double b = ray.originMm.x * ray.direction.x + ray.originMm.y * ray.direction.y;
    const double c = ray.originMm.x * ray.originMm.x + ray.originMm.y * ray.originMm.y - radiusMm * radiusMm;
    const double disc = b * b - a * c;
    if (disc < 0.0) return kInf;  // outside and missing: only through rounding at the wall
    // Larger root of a t² + 2 b t + c, written without cancellation.
    const double s = std::sqrt(disc);
    return b <= 0.0 ? (s - b) / a : -c / (b + s);
}

// Cosine-weighted direction about the unit normal n.
glm::dvec3 lambertian(const glm::dvec3& n, double u1, double u2) {
    const glm::dvec3 helper = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    const glm::dvec3 t1 = glm::normalize(glm::cross(helper, n));
    const glm::dvec3 t2 = glm::cross(n, t1);
    const double r = std::sqrt(u1), phi = 2.0 * std::numbers::pi * u2;
    return glm::normalize(r * std::cos(phi) * t1 + r * std::sin(phi) * t2 + std::sqrt(std::max(0.0, 1.0 - u1)) * n);
}

}  // namespace

PhotonTracer::PhotonTracer(const LensSystem& lens, const InteriorMaterials& materials, int maxBounces)
    : lens_(&lens), materials_(materials), maxBounces_(maxBounces) {
    const int n = lens.surfaceCount();
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
        // The iris blades reach the barrel on both sides of the stop.
        rim.extentMm = s.isStop ? std::max(k > 0 ? cells_[k].wallRadiusMm : 0.0, cells_[k + 1].wallRadiusMm)
                                : s.mechSemiDiameterMm;
        double sag = 0.0;
        double r = rim.extentMm;
        while (!s.sagMm(r * r, &sag) && r > 0.0) r *= 0.999;  // a conic ends before its rim
        rim.zMm = s.vertexZMm + sag;
    }
}

void PhotonTracer::trace(const SpectralIndices& indices, const Ray& start, Rng& rng, PhotonHistory& h) const {
    const LensSystem& lens = *lens_;
    const int n = lens.surfaceCount();
    h = PhotonHistory{};
    Ray ray = start;
    int cell = 0;
    int onSurface = -1;  // the surface the photon stands on, if any
    PathKey key = 0;
    bool scattered = false;

    // Appends a specular reflection at `surface` (n: the sensor); false if the limit stops it.
    auto addReflection = [&](int surface) {
        if (maxBounces_ >= 0 && h.reflections >= maxBounces_) return false;
        const int count = h.reflections++;
        if (key == kLongPathKey || count >= kPathKeyMaxReflections) {
            key = kLongPathKey;
        } else {
            const PathKey low = key & ((PathKey{1} << 56) - 1);
            key = (static_cast<PathKey>(count + 1) << 56) | low | (static_cast<PathKey>(surface & 0xff) << (8 * count));
        }
        return true;
    };
    // A diffuse bounce off the interior with probability `albedo` (analog absorption otherwise).
    auto scatterOff = [&](double albedo, const glm::dvec3& normalTowardsPhoton) {
        if (albedo <= 0.0 || rng.uniform() >= albedo) return false;
        const double u1 = rng.uniform(), u2 = rng.uniform();
        ray.direction = lambertian(normalTowardsPhoton, u1, u2);
        scattered = true;
        ++h.scatters;
        return true;
    };

    while (h.events < kMaxPhotonEvents) {
        enum class Kind { None, Behind, Ahead, Wall, SensorPlane } kind = Kind::None;
        double best = kInf;
        glm::dvec3 wallNormal(0.0);

        auto trySurface = [&](int k, Kind which) {
            // A ray near the wall can cross the surface's continuation beyond its rim (where the
            // surface does not exist) before crossing the surface itself: look past such hits.
            double tMin = k == onSurface ? kLeaveSurfaceMm : kMinStepMm;
            for (int crossing = 0; crossing < 3; ++crossing) {
                const SurfaceHit hit = intersect(lens.surface(k), ray, tMin);
                if (hit.status != HitStatus::Hit || hit.tMm >= best) return;
                const glm::dvec3 p = ray.at(hit.tMm);
                if (p.x * p.x + p.y * p.y <= rims_[k].extentMm * rims_[k].extentMm * (1.0 + kSeamTolerance)) {
                    best = hit.tMm;
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
            if (t > kMinStepMm && t < best) best = t, kind = Kind::SensorPlane;
        }
        if (cell > 0) {
            const double wall = cells_[cell].wallRadiusMm;
            const double tCylinder = cylinderExit(ray, wall);
            if (tCylinder > kMinStepMm && tCylinder < best) {
                best = tCylinder, kind = Kind::Wall;
                const glm::dvec3 p = ray.at(tCylinder);
                wallNormal = glm::normalize(glm::dvec3(-p.x, -p.y, 0.0));
            }
            // Annuli between a surface's rim and the wall, at the rim's z.
            auto tryAnnulus = [&](int k, double facing) {
                if (ray.direction.z * facing >= 0.0) return;  // moving away from it
                const double t = (rims_[k].zMm - ray.originMm.z) / ray.direction.z;
                if (t <= kMinStepMm || t >= best) return;
                const glm::dvec3 p = ray.at(t);
                const double r2 = p.x * p.x + p.y * p.y;
                if (r2 < rims_[k].extentMm * rims_[k].extentMm * (1.0 - kSeamTolerance) ||
                    r2 > wall * wall * (1.0 + kSeamTolerance))
                    return;
                best = t, kind = Kind::Wall;
                wallNormal = glm::dvec3(0.0, 0.0, facing);
            };
            tryAnnulus(cell - 1, 1.0);            // behind the photon, facing +z
            if (cell < n) tryAnnulus(cell, -1.0);  // ahead, facing −z
        }

        if (kind == Kind::None) {
            h.fate = cell == 0 ? PhotonFate::Escaped : PhotonFate::Lost;
            return;
        }
        ++h.events;
        const glm::dvec3 p = ray.at(best);
        ray.originMm = p;
        onSurface = -1;

        if (kind == Kind::Wall) {
            const bool edge = cells_[cell].glass;
            if (!scatterOff(edge ? materials_.edgeAlbedo : materials_.housingAlbedo, wallNormal)) {
                h.fate = edge ? PhotonFate::AbsorbedEdge : PhotonFate::AbsorbedHousing;
                return;
            }
            continue;
        }

        if (kind == Kind::SensorPlane) {
            const bool onSensor = std::abs(p.x) <= 0.5 * lens.sensor().widthMm && std::abs(p.y) <= 0.5 * lens.sensor().heightMm;
            if (!onSensor) {  // the camera body around the sensor
                if (!scatterOff(materials_.housingAlbedo, {0.0, 0.0, -1.0})) {
                    h.fate = PhotonFate::AbsorbedHousing;
                    return;
                }
                continue;
            }
            if (h.arrivalCount == kMaxSensorArrivals) {
                h.fate = PhotonFate::EventLimit;
                return;
            }
            h.arrivals[h.arrivalCount++] = {{p.x, p.y}, key, scattered};
            if (rng.uniform() >= lens.sensor().reflectance) {
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
            if (!scatterOff(materials_.irisAlbedo, towardsPhoton)) {
                h.fate = PhotonFate::AbsorbedIris;
                return;
            }
            continue;
        }
        if (p.x * p.x + p.y * p.y > surface.semiApertureMm * surface.semiApertureMm) {
            // Outside the clear aperture the surface is covered by its retaining ring.
            glm::dvec3 normal = surface.normalAt(p);
            if (glm::dot(normal, ray.direction) > 0.0) normal = -normal;
            if (!scatterOff(materials_.housingAlbedo, normal)) {
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
        const glm::dvec3 normal = surface.normalAt(p);
        const double cosThetaI = std::min(1.0, std::abs(glm::dot(normal, ray.direction)));
        const FresnelTerms response = interfaceResponse(lens, indices, k, forward ? 1 : -1, cosThetaI);
        const double reflectance = response.totalInternalReflection ? 1.0 : response.reflectance();
        glm::dvec3 refracted;
        if (rng.uniform() < reflectance || !refract(ray.direction, normal, n1, n2, &refracted)) {
            if (!addReflection(k)) {
                h.fate = PhotonFate::BounceLimit;
                return;
            }
            ray.direction = glm::normalize(reflect(ray.direction, normal));
            continue;
        }
        ray.direction = refracted;
        if (k == 0 && forward) h.entered = true;
        cell = other;
    }
    h.fate = PhotonFate::EventLimit;
}

}  // namespace flare
