#include "flare/ghosts/Ghosts.h"

#include <cmath>
#include <cstdio>

#include "flare/optics/Paraxial.h"
#include "flare/optics/SequentialTracer.h"

namespace flare {

std::string GhostPath::label() const {
    std::string label = "ghost";
    char buffer[16];
    for (int r : reflections) {
        std::snprintf(buffer, sizeof buffer, "_%02d", r + 1);
        label += buffer;
    }
    return label;
}

std::vector<int> GhostPath::surfaceNumbers() const {
    std::vector<int> numbers;
    for (int r : reflections) numbers.push_back(r + 1);
    return numbers;
}

std::vector<int> reflectingSurfaces(const LensSystem& lens, bool includeSensor) {
    std::vector<int> surfaces;
    for (int i = 0; i < lens.surfaceCount(); ++i)
        if (lens.isReflecting(i)) surfaces.push_back(i);
    if (includeSensor) surfaces.push_back(lens.surfaceCount());
    return surfaces;
}

namespace {

// Extends `prefix` (which ends travelling in `direction`) by the remaining reflections: a forward
// traveller can next reflect at any surface beyond its last one, a backward one at any before it.
void extend(const std::vector<int>& surfaces, std::vector<int>& prefix, int remaining,
            std::vector<GhostPath>& out) {
    if (remaining == 0) {
        out.push_back({prefix});
        return;
    }
    const bool forward = prefix.size() % 2 == 0;
    const int last = prefix.empty() ? -1 : prefix.back();
    for (int s : surfaces) {
        if (forward ? s <= last : s >= last) continue;
        prefix.push_back(s);
        extend(surfaces, prefix, remaining - 1, out);
        prefix.pop_back();
    }
}

}  // namespace

std::vector<GhostPath> enumerateGhosts(const LensSystem& lens, int order, bool includeSensor) {
    const std::vector<int> surfaces = reflectingSurfaces(lens, includeSensor);
    std::vector<GhostPath> paths;
    std::vector<int> prefix;
    extend(surfaces, prefix, order, paths);
    return paths;
}

namespace {

double surfaceReflectance(const LensSystem& lens, const SpectralIndices& indices, int k) {
    return k == lens.surfaceCount() ? lens.sensor().reflectance
                                    : interfaceResponse(lens, indices, k, 1, 1.0).reflectance();
}

}  // namespace

double normalIncidenceReflectance(const LensSystem& lens, const SpectralIndices& indices, const GhostPath& path) {
    double product = 1.0;
    for (int k : path.reflections) product *= surfaceReflectance(lens, indices, k);
    return product;
}

double higherOrderShareEstimate(const LensSystem& lens, const SpectralIndices& indices, bool includeSensor) {
    double sum = 0.0, sumSquares = 0.0;
    for (int k : reflectingSurfaces(lens, includeSensor)) {
        const double r = surfaceReflectance(lens, indices, k);
        sum += r;
        sumSquares += r * r;
    }
    return 0.25 * 0.5 * (sum * sum - sumSquares);
}

GhostParaxial analyseGhostParaxial(const LensSystem& lens, const SpectralIndices& indices,
                                   const GhostPath& path) {
    const int sensor = lens.surfaceCount();
    const double entranceRadius = 0.5 * analyseParaxial(lens, indices.wavelengthNm).entrancePupilDiameterMm;

    GhostParaxial result;
    // Two rays at once: the unit-height ray for the ghost's EFL and focus, the marginal ray for
    // the heights. Slopes are per unit of travel along the current direction.
    struct State { double y, u; };
    State unit{1.0, 0.0}, marginal{entranceRadius, 0.0};
    double z = lens.surface(0).vertexZMm, n = indices.n[0];
    int position = -1, direction = 1;
    size_t next = 0;
    while (true) {
        const int k = position + direction;
        const double zk = k == sensor ? lens.sensorZMm() : lens.surface(k).vertexZMm;
        const double travel = direction * (zk - z);
        unit.y += unit.u * travel;
        marginal.y += marginal.u * travel;
        z = zk;
        position = k;
        result.marginalHeightsMm.push_back(marginal.y);
        const bool reflectHere = next < path.reflections.size() && path.reflections[next] == k;
        if (k == sensor && !reflectHere) break;
        if (k < 0) return result;  // malformed path: left through the front
        const double curvature = k == sensor ? 0.0 : direction * lens.surface(k).curvature();
        if (reflectHere) {
            unit.u += 2.0 * curvature * unit.y;
            marginal.u += 2.0 * curvature * marginal.y;
            direction = -direction;
            ++next;
        } else if (!lens.surface(k).isStop) {
            const double nAfter = direction > 0 ? indices.n[k + 1] : indices.n[k];
            unit.u = (n * unit.u - unit.y * curvature * (nAfter - n)) / nAfter;
            marginal.u = (n * marginal.u - marginal.y * curvature * (nAfter - n)) / nAfter;
            n = nAfter;
        }
    }
    // The paraxial image lies where the unit ray's final segment crosses the axis; the ray ends on
    // the sensor plane, so that crossing is at −y/u from the sensor.
    if (unit.u != 0.0) {
        result.eflMm = -1.0 / (n * unit.u);
        result.focusFromSensorMm = -unit.y / unit.u;
    }
    const std::vector<double>& h = result.marginalHeightsMm;
    for (size_t i = 0; i + 2 < h.size(); ++i)
        if (h[i] * h[i + 1] < 0.0) result.internalFocus = true;
    return result;
}

}  // namespace flare
