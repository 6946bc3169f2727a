#include "flare/ghosts/GhostRinging.h"

#include <cmath>
#include <vector>

#include "flare/core/FresnelIntegrals.h"

namespace flare {

namespace {

// One event of a path, as the paraxial trace meets it: a vertex plane (or the sensor) with the
// curvature the light sees there (the sign follows the direction of travel), what happens there,
// and the indices on either side.
struct Event {
    double zMm = 0.0;
    int direction = 1;  // of travel towards the event
    double curvature = 0.0;
    enum Kind { Refract, Reflect, Stop, Sensor } kind = Refract;
    double nBefore = 1.0, nAfter = 1.0;
};

// The path's events in order, or empty for a malformed path.
std::vector<Event> pathEvents(const LensSystem& lens, const SpectralIndices& indices, const GhostPath& path) {
    std::vector<Event> events;
    const int sensor = lens.surfaceCount();
    int position = -1, direction = 1;
    double n = indices.n[0];
    size_t next = 0;
    while (true) {
        const int k = position + direction;
        if (k < 0) return {};
        Event e;
        e.zMm = k == sensor ? lens.sensorZMm() : lens.surface(k).vertexZMm;
        e.direction = direction;
        e.nBefore = n;
        position = k;
        const bool reflectHere = next < path.reflections.size() && path.reflections[next] == k;
        if (k == sensor && !reflectHere) {
            e.kind = Event::Sensor;
            e.nAfter = n;
            events.push_back(e);
            return events;
        }
        e.curvature = k == sensor ? 0.0 : direction * lens.surface(k).curvature();
        if (reflectHere) {
            e.kind = Event::Reflect;
            e.nAfter = n;
            direction = -direction;
            ++next;
        } else if (lens.surface(k).isStop) {
            e.kind = Event::Stop;
            e.nAfter = n;
        } else {
            e.nAfter = direction > 0 ? indices.n[k + 1] : indices.n[k];
            n = e.nAfter;
        }
        events.push_back(e);
        if (events.size() > 4096) return {};
    }
}

// A paraxial ray (height, slope along the direction of travel) from event `from` (just after it)
// to the end; calls `atStop(index, y)` at every stop crossing on the way, and returns the height
// on the sensor.
template <typename AtStop>
double traceFrom(const std::vector<Event>& events, size_t from, double y, double u, AtStop atStop) {
    double z = events[from].zMm;
    for (size_t i = from + 1; i < events.size(); ++i) {
        const Event& e = events[i];
        y += u * e.direction * (e.zMm - z);
        z = e.zMm;
        switch (e.kind) {
            case Event::Reflect: u += 2.0 * e.curvature * y; break;
            case Event::Refract: u = (e.nBefore * u - y * e.curvature * (e.nAfter - e.nBefore)) / e.nAfter; break;
            case Event::Stop: atStop(i, y); break;
            case Event::Sensor: break;
        }
    }
    return y;
}

}  // namespace

double GhostFresnelScale::edgeScaleMm(double wavelengthNm) const {
    return std::sqrt(0.5 * wavelengthNm * 1e-6 * distanceMm);
}

double GhostFresnelScale::fresnelNumber(double wavelengthNm) const {
    return distanceMm > 0.0 ? imageRadiusMm * imageRadiusMm / (wavelengthNm * 1e-6 * distanceMm) : INFINITY;
}

GhostFresnelScale ghostFresnelScale(const LensSystem& lens, const SpectralIndices& indices, const GhostPath& path) {
    GhostFresnelScale out;
    if (lens.stopIndex() < 0 || lens.surfaceCount() == 0) return out;
    std::vector<Event> events = pathEvents(lens, indices, path);
    if (events.empty()) return out;
    // A start event before the first vertex: the marginal ray (unit height, parallel).
    Event start;
    start.zMm = events.front().zMm;
    events.insert(events.begin(), start);
    std::vector<std::pair<size_t, double>> crossings;  // (event, marginal height)
    const double sensorHeight = traceFrom(events, 0, 1.0, 0.0, [&](size_t i, double y) { crossings.emplace_back(i, y); });
    if (crossings.empty()) return out;
    size_t widest = 0;
    for (size_t c = 1; c < crossings.size(); ++c)
        if (std::abs(crossings[c].second) > std::abs(crossings[widest].second)) widest = c;
    const auto [event, height] = crossings[widest];
    if (!(std::abs(height) > 0.0)) return out;
    // B: the sensor height of a ray leaving the stop's centre with unit reduced slope (n·u = 1).
    const double b = traceFrom(events, event, 0.0, 1.0 / events[event].nAfter, [](size_t, double) {});
    // G: a ray from direction θ through the stop's edge (height r at the crossing) enters at
    // h = (r − s·θ) / r₁ (r₁: the unit marginal ray's height there, s: the height of a ray
    // entering at the vertex with unit slope) and lands at p·h + q·θ (p, q: their sensor
    // heights), so the rim moves by q − p·s / r₁ per radian.
    double fieldHeightAtStop = 0.0;
    const double fieldSensorHeight = traceFrom(events, 0, 0.0, 1.0, [&](size_t i, double y) {
        if (i == event) fieldHeightAtStop = y;
    });
    out.fieldShiftMmPerRad = fieldSensorHeight - sensorHeight * fieldHeightAtStop / height;
    out.magnification = sensorHeight / height;
    out.distanceMm = std::abs(out.magnification * b);
    out.imageRadiusMm = std::abs(out.magnification) * lens.iris().radiusMm();
    out.stopCrossing = static_cast<int>(widest);
    out.valid = std::isfinite(out.distanceMm) && std::isfinite(out.fieldShiftMmPerRad);
    return out;
}

bool ghostRipplesVisible(const GhostFresnelScale& scale, double wavelengthNm, double apparentRadiusRad) {
    if (!scale.valid || !(scale.fresnelNumber(wavelengthNm) >= kMinRingingFresnelNumber)) return false;
    static const double smearLimit = FresnelEdgeExcess::instance().smearRadiusFor(kMinSmearedRipple);
    const double smearMm = std::abs(scale.fieldShiftMmPerRad) * apparentRadiusRad;
    return smearMm < smearLimit * scale.edgeScaleMm(wavelengthNm);
}

}  // namespace flare
