#include "flare/optics/SequentialTracer.h"

#include <cmath>

#include <glm/geometric.hpp>

#include "flare/optics/Fresnel.h"

namespace flare {

const char* toString(TraceStatus status) {
    switch (status) {
        case TraceStatus::Ok: return "ok";
        case TraceStatus::Missed: return "missed";
        case TraceStatus::Vignetted: return "vignetted";
        case TraceStatus::BlockedByIris: return "blocked_by_iris";
        case TraceStatus::TotalInternalReflection: return "total_internal_reflection";
        case TraceStatus::NewtonDiverged: return "newton_diverged";
        case TraceStatus::WrongExit: return "wrong_exit";
    }
    return "?";
}

FresnelTerms interfaceResponse(const LensSystem& lens, const SpectralIndices& indices, int k,
                               int direction, double cosThetaI) {
    const double nBefore = indices.n[k], nAfter = indices.n[k + 1];
    const double n1 = direction > 0 ? nBefore : nAfter;
    const double n2 = direction > 0 ? nAfter : nBefore;
    if (const Coating* coating = lens.coating(k)) {
        const bool airBefore = lens.mediumBefore(k).isAir();
        const bool fromAirSide = (direction > 0) == airBefore;
        const double nAir = airBefore ? nBefore : nAfter;
        const double nGlass = airBefore ? nAfter : nBefore;
        return thinFilmResponse(*coating, cosThetaI, nAir, nGlass, fromAirSide, indices.wavelengthNm);
    }
    return fresnelDielectric(cosThetaI, n1, n2);
}

double interfaceReflectanceBound(const LensSystem& lens, const SpectralIndices& indices, int k, int direction,
                                 double cosThetaI) {
    const Coating* coating = lens.coating(k);
    if (!coating) return 1.0;
    const double nBefore = indices.n[k], nAfter = indices.n[k + 1];
    const bool airBefore = lens.mediumBefore(k).isAir();
    const bool fromAirSide = (direction > 0) == airBefore;
    const double nAir = airBefore ? nBefore : nAfter;
    const double nGlass = airBefore ? nAfter : nBefore;
    const double bound = thinFilmReflectanceBound(*coating, cosThetaI, nAir, nGlass, fromAirSide);
    return bound >= 1.0 ? 1.0 : bound * (1.0 + kReflectanceBoundMargin) + kReflectanceBoundFloor;
}

namespace {

TraceResult fail(TraceResult result, TraceStatus status, int surface) {
    result.status = status;
    result.surface = surface;
    result.throughput = 0.0;
    return result;
}

}  // namespace

TraceResult tracePath(const LensSystem& lens, const SpectralIndices& indices, const Ray& ray,
                      const SequentialPath& path, const TraceOptions& options) {
    const int count = lens.surfaceCount();
    const int sensor = count;
    TraceResult result;
    result.ray = ray;
    result.throughput = 1.0;
    if (options.pathPointsMm) options.pathPointsMm->push_back(ray.originMm);
    if (options.pathSurfaces) options.pathSurfaces->push_back(path.start);

    int position = path.start;
    int direction = path.direction;
    size_t nextReflection = 0;
    // Each step meets one surface; a path cannot meet more than this many.
    const int maxSteps = (count + 1) * static_cast<int>(path.reflections.size() + 2);
    for (int step = 0; step < maxSteps; ++step) {
        const int k = position + direction;
        const bool reflectHere =
            nextReflection < path.reflections.size() && path.reflections[nextReflection] == k;

        if (k < 0) {  // left through the front
            if (path.end == SequentialPath::End::ObjectSpace && nextReflection == path.reflections.size()) {
                result.status = TraceStatus::Ok;
                result.surface = -1;
                return result;
            }
            return fail(result, TraceStatus::WrongExit, -1);
        }

        if (k == sensor) {
            const double dz = result.ray.direction.z;
            if (dz <= 0.0) return fail(result, TraceStatus::Missed, sensor);
            const double t = (lens.sensorZMm() - result.ray.originMm.z) / dz;
            result.ray.originMm = result.ray.at(t);
            ++result.interactions;
            if (options.pathPointsMm) options.pathPointsMm->push_back(result.ray.originMm);
            if (options.pathSurfaces) options.pathSurfaces->push_back(sensor);
            if (reflectHere) {
                // Only the sensor itself reflects; around it is the dark camera body.
                const glm::dvec3& q = result.ray.originMm;
                if (options.clipApertures && (std::abs(q.x) > 0.5 * lens.sensor().widthMm ||
                                              std::abs(q.y) > 0.5 * lens.sensor().heightMm))
                    return fail(result, TraceStatus::Vignetted, sensor);
                result.ray.direction = reflect(result.ray.direction, glm::dvec3(0.0, 0.0, 1.0));
                if (options.fresnelWeights) result.throughput *= lens.sensor().reflectance;
                ++nextReflection;
                direction = -1;
                position = sensor;
                continue;
            }
            if (path.end == SequentialPath::End::Sensor && nextReflection == path.reflections.size()) {
                result.status = TraceStatus::Ok;
                result.surface = sensor;
                return result;
            }
            return fail(result, TraceStatus::WrongExit, sensor);
        }

        const Surface& surface = lens.surface(k);
        const SurfaceHit hit = intersect(surface, result.ray);
        if (hit.status != HitStatus::Hit)
            return fail(result, hit.status == HitStatus::NewtonDiverged ? TraceStatus::NewtonDiverged
                                                                        : TraceStatus::Missed,
                        k);
        const glm::dvec3 p = result.ray.at(hit.tMm);
        result.ray.originMm = p;
        ++result.interactions;
        if (options.pathPointsMm) options.pathPointsMm->push_back(p);
        if (options.pathSurfaces) options.pathSurfaces->push_back(k);
        position = k;

        if (surface.isStop) {
            if (options.clipApertures && !lens.iris().contains(p.x, p.y))
                return fail(result, TraceStatus::BlockedByIris, k);
            continue;  // the stop plane does not bend light
        }
        if (options.clipApertures &&
            p.x * p.x + p.y * p.y > surface.semiApertureMm * surface.semiApertureMm)
            return fail(result, TraceStatus::Vignetted, k);

        const glm::dvec3 normal = surface.normalAt(p);
        const double cosThetaI = std::abs(glm::dot(normal, result.ray.direction));
        const double nBefore = indices.n[k], nAfter = indices.n[k + 1];
        const double n1 = direction > 0 ? nBefore : nAfter;
        const double n2 = direction > 0 ? nAfter : nBefore;
        if (reflectHere) {
            if (options.fresnelWeights)
                result.throughput *= interfaceResponse(lens, indices, k, direction, cosThetaI).reflectance();
            result.ray.direction = glm::normalize(reflect(result.ray.direction, normal));
            direction = -direction;
            ++nextReflection;
        } else {
            glm::dvec3 refracted;
            if (!refract(result.ray.direction, normal, n1, n2, &refracted))
                return fail(result, TraceStatus::TotalInternalReflection, k);
            if (options.fresnelWeights && n1 != n2)
                result.throughput *=
                    interfaceResponse(lens, indices, k, direction, cosThetaI).transmittance();
            result.ray.direction = refracted;
        }
    }
    return fail(result, TraceStatus::WrongExit, position);
}

TraceResult traceForward(const LensSystem& lens, const SpectralIndices& indices, const Ray& ray,
                         const TraceOptions& options) {
    return tracePath(lens, indices, ray, SequentialPath{}, options);
}

TraceResult traceBackward(const LensSystem& lens, const SpectralIndices& indices, const Ray& ray,
                          const TraceOptions& options) {
    SequentialPath path;
    path.start = lens.surfaceCount();
    path.direction = -1;
    path.end = SequentialPath::End::ObjectSpace;
    return tracePath(lens, indices, ray, path, options);
}

}  // namespace flare
