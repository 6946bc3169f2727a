#include "flare/optics/BundleTracer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include "flare/optics/Fresnel.h"

namespace flare {

namespace {

constexpr int kBatch = 64;  // rays traced together: enough to overlap their latencies, fits in L1

// A sphere's hit uses intersectConic (inline in Surface.h) and its normal the same expression as
// Surface::normalAt, so that the results equal tracePath's to the last bit (the tests check it);
// inline, consecutive rays' long divisions and square roots overlap, which calls into other
// translation units prevent.
inline glm::dvec3 sphereNormal(const Surface& s, const glm::dvec3& p) {
    return (glm::dvec3(0.0, 0.0, s.vertexZMm + s.radiusMm) - p) / s.radiusMm;
}

}  // namespace

bool BundleLanding::onSensor(const LensSystem& lens) const {
    return ok() && std::abs(sensorMm.x) <= 0.5 * lens.sensor().widthMm &&
           std::abs(sensorMm.y) <= 0.5 * lens.sensor().heightMm;
}

double sensorMargin(const LensSystem& lens, const glm::dvec2& sensorMm) {
    const double u = sensorMm.x / (0.5 * lens.sensor().widthMm), v = sensorMm.y / (0.5 * lens.sensor().heightMm);
    return std::max(u * u, v * v) - 1.0;
}

// The event sequence of a path does not depend on the ray (only whether the ray survives each
// event does), so it is unrolled once here, following tracePath's control flow step by step.
InterfaceTables::InterfaceTables(const LensSystem& lens, const SpectralIndices& indices, int intervals,
                                 std::span<const Interface> only, bool slopesFromValues)
    : lens_(&lens), indices_(indices), intervals_(std::max(intervals, 1)),
      tables_(static_cast<size_t>(lens.surfaceCount()) * 4) {
    const double h = 1.0 / intervals_;
    auto wanted = [&](int k, int direction) {
        return only.empty() || std::any_of(only.begin(), only.end(), [&](const Interface& i) {
                   return i.surface == k && i.direction == direction;
               });
    };
    // The interfaces in parallel (each fills its own two tables): a lens's tables cost a few
    // milliseconds, which the analysis and the preview would otherwise wait for.
    std::vector<std::pair<int, int>> interfaces;
    for (int k = 0; k < lens.surfaceCount(); ++k)
        for (int direction : {-1, 1})
            if (!lens.surface(k).isStop && wanted(k, direction)) interfaces.emplace_back(k, direction);
    tbb::parallel_for(size_t{0}, interfaces.size(), [&](size_t n) {
        const auto [k, direction] = interfaces[n];
        const double n1 = direction > 0 ? indices.n[k] : indices.n[k + 1];
        const double n2 = direction > 0 ? indices.n[k + 1] : indices.n[k];
        // Total internal reflection below cos = √(1 − (n2/n1)²): the response has a
        // square-root edge there, steep over a few hundredths in cos; it is evaluated
        // exactly from two intervals below to 0.05 above.
        double exactFrom = 2.0, exactTo = -1.0;
        if (n1 > n2) {
            const double critical = std::sqrt(1.0 - (n2 / n1) * (n2 / n1));
            exactFrom = critical - 2.0 * h;
            exactTo = critical + 0.05;
        }
        // Each response gives both factors: one evaluation per point fills both tables.
        Table& transmit = tables_[(static_cast<size_t>(k) * 2 + (direction > 0 ? 1 : 0)) * 2];
        Table& reflect = tables_[(static_cast<size_t>(k) * 2 + (direction > 0 ? 1 : 0)) * 2 + 1];
        for (Table* t : {&transmit, &reflect}) {
            t->exactFrom = exactFrom;
            t->exactTo = exactTo;
            t->value.resize(intervals_ + 1);
            t->slope.resize(intervals_ + 1);
        }
        auto f = [&](double c) { return interfaceResponse(lens, indices, k, direction, std::clamp(c, 0.0, 1.0)); };
        // Slopes by central differences (one-sided at the ends): with a step of 1e-6 the
        // rounding error (~1e-10) and the truncation error (~1e-12 times the third
        // derivative) of a slope move the interpolant by about 1e-13.
        constexpr double d = 1e-6;
        for (int i = 0; i <= intervals_; ++i) {
            const FresnelTerms at = f(i * h);
            transmit.value[i] = at.transmittance();
            reflect.value[i] = at.reflectance();
        }
        for (int i = 0; i <= intervals_; ++i) {
            const double c = i * h;
            // slopesFromValues: fourth-order central differences of the values,
            // (−v[i+2] + 8 v[i+1] − 8 v[i−1] + v[i−2]) / 12h, one response per point; not at the
            // two points at each end, nor where the stencil would reach across total internal
            // reflection's edge (up to 0.1 beyond the exact zone: a square-root edge has large
            // higher derivatives).
            const bool nearEdge = c >= exactFrom - 3.0 * h && c <= exactTo + 0.1;
            if (slopesFromValues && i >= 2 && i <= intervals_ - 2 && !nearEdge) {
                for (Table* t : {&transmit, &reflect}) {
                    const std::vector<double>& v = t->value;
                    t->slope[i] = (-v[i + 2] + 8.0 * v[i + 1] - 8.0 * v[i - 1] + v[i - 2]) / (12.0 * h);
                }
                continue;
            }
            const double lo = std::max(0.0, c - d), hi = std::min(1.0, c + d);
            const FresnelTerms below = f(lo), above = f(hi);
            transmit.slope[i] = (above.transmittance() - below.transmittance()) / (hi - lo);
            reflect.slope[i] = (above.reflectance() - below.reflectance()) / (hi - lo);
        }
    });
}

double InterfaceTables::lookup(const Table& t, int surface, int direction, bool reflect, double cosThetaI) const {
    const double c = std::clamp(cosThetaI, 0.0, 1.0);
    if ((c >= t.exactFrom && c <= t.exactTo) || t.value.empty()) {  // (empty: not tabulated)
        const FresnelTerms exact = interfaceResponse(*lens_, indices_, surface, direction, c);
        return reflect ? exact.reflectance() : exact.transmittance();
    }
    const double x = c * intervals_;
    const int i = std::min(static_cast<int>(x), intervals_ - 1);
    const double u = x - i, h = 1.0 / intervals_;
    // Cubic Hermite basis on [i, i + 1].
    const double u2 = u * u, u3 = u2 * u;
    return (2 * u3 - 3 * u2 + 1) * t.value[i] + (u3 - 2 * u2 + u) * h * t.slope[i] + (-2 * u3 + 3 * u2) * t.value[i + 1] +
           (u3 - u2) * h * t.slope[i + 1];
}

double InterfaceTables::reflectance(int surface, int direction, double cosThetaI) const {
    return lookup(table(surface, direction, true), surface, direction, true, cosThetaI);
}

double InterfaceTables::transmittance(int surface, int direction, double cosThetaI) const {
    return lookup(table(surface, direction, false), surface, direction, false, cosThetaI);
}

BundleTracer::BundleTracer(const LensSystem& lens, const SpectralIndices& indices, std::span<const int> reflections,
                           bool fresnelWeights, const InterfaceTables* tables)
    : lens_(&lens), indices_(indices), reflections_(reflections.begin(), reflections.end()),
      fresnelWeights_(fresnelWeights), tables_(tables) {
    const int count = lens.surfaceCount();
    const int sensor = count;
    int position = -1, direction = 1;
    size_t next = 0;
    const int maxSteps = (count + 1) * static_cast<int>(reflections.size() + 2);
    for (int step = 0; step < maxSteps; ++step) {
        const int k = position + direction;
        const bool reflectHere = next < reflections.size() && reflections[next] == k;
        Step s;
        s.surface = k;
        s.direction = direction;
        if (k < 0) {  // left through the front: never right for a path that ends on the sensor
            s.kind = Step::Kind::WrongExit;
            steps_.push_back(s);
            return;
        }
        if (k == sensor) {
            if (reflectHere) {
                s.kind = Step::Kind::SensorReflect;
                steps_.push_back(s);
                ++next;
                direction = -1;
                position = sensor;
                continue;
            }
            s.kind = next == reflections.size() ? Step::Kind::SensorEnd : Step::Kind::SensorWrongExit;
            steps_.push_back(s);
            return;
        }
        position = k;
        if (lens.surface(k).isStop) {  // tracePath never reflects at the stop
            s.kind = Step::Kind::Stop;
            steps_.push_back(s);
            continue;
        }
        const double nBefore = indices.n[k], nAfter = indices.n[k + 1];
        s.n1 = direction > 0 ? nBefore : nAfter;
        s.n2 = direction > 0 ? nAfter : nBefore;
        s.kind = reflectHere ? Step::Kind::Reflect : Step::Kind::Refract;
        const Surface& surface = lens.surface(k);
        s.sphere = surface.radiusMm != 0.0 && surface.conic == 0.0 && !surface.hasPolynomial();
        s.weighted = fresnelWeights_ && (reflectHere || s.n1 != s.n2);
        steps_.push_back(s);
        if (reflectHere) {
            direction = -direction;
            ++next;
        }
    }
    Step s;
    s.kind = Step::Kind::WrongExit;
    s.surface = position;
    steps_.push_back(s);
}

void BundleTracer::trace(const PupilGrid& grid, std::span<const glm::dvec2> pupilMm,
                         std::span<BundleLanding> out) const {
    BundleRay rays[kBatch];
    StepOutcome outcomes[kBatch];
    int index[kBatch];  // which input each surviving ray is, in order
    for (size_t begin = 0; begin < pupilMm.size(); begin += kBatch) {
        const int count = static_cast<int>(std::min<size_t>(kBatch, pupilMm.size() - begin));
        for (int i = 0; i < count; ++i) {
            rays[i] = {grid.ray(pupilMm[begin + i].x, pupilMm[begin + i].y), 1.0};
            index[i] = i;
        }
        int n = count;
        for (const Step& step : steps_) {
            applyStep(step, rays, outcomes, n, false);
            int m = 0;
            for (int j = 0; j < n; ++j) {
                if (!outcomes[j].alive) {
                    BundleLanding& o = out[begin + index[j]];
                    o = BundleLanding{};
                    o.status = outcomes[j].failure;
                    o.surface = step.surface;
                    continue;
                }
                rays[m] = rays[j];
                index[m++] = index[j];
            }
            n = m;
        }
        // Only a path's last step (the sensor plane) lets rays through to here.
        for (int j = 0; j < n; ++j) {
            BundleLanding& o = out[begin + index[j]];
            o.sensorMm = {rays[j].ray.originMm.x, rays[j].ray.originMm.y};
            o.throughput = rays[j].throughput;
            o.status = TraceStatus::Ok;
            o.surface = lens_->surfaceCount();
        }
    }
}

std::vector<InterfaceTables::Interface> BundleTracer::interfaces() const {
    std::vector<InterfaceTables::Interface> out;
    for (const Step& s : steps_) {
        if (s.kind != Step::Kind::Refract && s.kind != Step::Kind::Reflect) continue;
        const bool seen = std::any_of(out.begin(), out.end(), [&](const InterfaceTables::Interface& i) {
            return i.surface == s.surface && i.direction == s.direction;
        });
        if (!seen) out.push_back({s.surface, s.direction});
    }
    return out;
}

BundleTracer BundleTracer::geometryOnly() const {
    BundleTracer copy = *this;
    copy.fresnelWeights_ = false;
    for (Step& s : copy.steps_) s.weighted = false;
    return copy;
}

BundleLanding BundleTracer::trace(const PupilGrid& grid, const glm::dvec2& pupilMm) const {
    BundleLanding out;
    trace(grid, std::span<const glm::dvec2>(&pupilMm, 1), std::span<BundleLanding>(&out, 1));
    return out;
}

void BundleTracer::advance(int step, std::span<BundleRay> rays, std::span<StepOutcome> outcomes, bool margins) const {
    for (size_t begin = 0; begin < rays.size(); begin += kBatch) {
        const int count = static_cast<int>(std::min<size_t>(kBatch, rays.size() - begin));
        applyStep(steps_[step], rays.data() + begin, outcomes.data() + begin, count, margins);
    }
}

// One event for up to kBatch rays, split into short loops over the rays still going (intersect
// and clip; normal and incidence; Fresnel weight; new direction) so that consecutive iterations
// are independent and the processor overlaps them. The operations and their order are
// tracePath's, so surviving rays carry bit-identical state.
void BundleTracer::applyStep(const Step& s, BundleRay* rays, StepOutcome* out, int count, bool margins) const {
    constexpr double kUndefined = std::numeric_limits<double>::quiet_NaN();
    int lanes[kBatch];
    glm::dvec3 normals[kBatch];
    double cosines[kBatch];
    for (int i = 0; i < count; ++i) out[i] = StepOutcome{};
    auto kill = [&](int i, TraceStatus failure, double margin) {
        out[i].alive = false;
        out[i].failure = failure;
        out[i].margin = margin;
    };
    const LensSystem& lens = *lens_;
    switch (s.kind) {
        case Step::Kind::WrongExit:
            for (int i = 0; i < count; ++i) kill(i, TraceStatus::WrongExit, kUndefined);
            return;
        case Step::Kind::SensorEnd:
        case Step::Kind::SensorWrongExit:
        case Step::Kind::SensorReflect: {
            const double halfW = 0.5 * lens.sensor().widthMm, halfH = 0.5 * lens.sensor().heightMm;
            for (int i = 0; i < count; ++i) {
                Ray& r = rays[i].ray;
                const double dz = r.direction.z;
                if (dz <= 0.0) {
                    kill(i, TraceStatus::Missed, kUndefined);
                    continue;
                }
                const double t = (lens.sensorZMm() - r.originMm.z) / dz;
                r.originMm = r.at(t);
                if (s.kind == Step::Kind::SensorWrongExit) {
                    kill(i, TraceStatus::WrongExit, kUndefined);
                    continue;
                }
                if (s.kind == Step::Kind::SensorEnd) continue;
                // Only the sensor itself reflects; around it is the dark camera body.
                const double q = margins ? sensorMargin(lens, {r.originMm.x, r.originMm.y}) : -1.0;
                if (std::abs(r.originMm.x) > halfW || std::abs(r.originMm.y) > halfH) {
                    kill(i, TraceStatus::Vignetted, q);
                    continue;
                }
                out[i].margin = q;
                r.direction = reflect(r.direction, glm::dvec3(0.0, 0.0, 1.0));
                if (fresnelWeights_) rays[i].throughput *= lens.sensor().reflectance;
            }
            return;
        }
        case Step::Kind::Stop: {
            const Surface& surface = lens.surface(s.surface);
            for (int i = 0; i < count; ++i) {
                Ray& r = rays[i].ray;
                const SurfaceHit hit = intersect(surface, r);
                if (hit.status != HitStatus::Hit) {
                    kill(i, hit.status == HitStatus::NewtonDiverged ? TraceStatus::NewtonDiverged : TraceStatus::Missed,
                         kUndefined);
                    continue;
                }
                r.originMm = r.at(hit.tMm);
                const double q = margins ? lens.iris().margin(r.originMm.x, r.originMm.y) : kUndefined;
                if (!lens.iris().contains(r.originMm.x, r.originMm.y)) {
                    kill(i, TraceStatus::BlockedByIris, q);
                    continue;
                }
                out[i].margin = margins ? q : -1.0;
            }
            return;
        }
        case Step::Kind::Refract:
        case Step::Kind::Reflect: {
            const Surface& surface = lens.surface(s.surface);
            const double aperture2 = surface.semiApertureMm * surface.semiApertureMm;
            const double inverseAperture2 = 1.0 / aperture2;
            int n = 0;
            for (int i = 0; i < count; ++i) {
                Ray& r = rays[i].ray;
                SurfaceHit hit;
                if (s.sphere)
                    hit = intersectConic(surface, r.originMm - glm::dvec3(0.0, 0.0, surface.vertexZMm), r.direction, 1e-9);
                else
                    hit = intersect(surface, r);
                if (hit.status != HitStatus::Hit) {
                    kill(i, hit.status == HitStatus::NewtonDiverged ? TraceStatus::NewtonDiverged : TraceStatus::Missed,
                         kUndefined);
                    continue;
                }
                r.originMm = r.at(hit.tMm);
                const glm::dvec3& p = r.originMm;
                const double r2 = p.x * p.x + p.y * p.y;
                out[i].margin = r2 * inverseAperture2 - 1.0;
                if (r2 > aperture2) {
                    kill(i, TraceStatus::Vignetted, out[i].margin);
                    continue;
                }
                lanes[n++] = i;
            }
            for (int j = 0; j < n; ++j) {
                const Ray& r = rays[lanes[j]].ray;
                normals[j] = s.sphere ? sphereNormal(surface, r.originMm) : surface.normalAt(r.originMm);
                cosines[j] = std::abs(glm::dot(normals[j], r.direction));
            }
            if (s.kind == Step::Kind::Reflect) {
                if (s.weighted && tables_)
                    for (int j = 0; j < n; ++j)
                        rays[lanes[j]].throughput *= tables_->reflectance(s.surface, s.direction, cosines[j]);
                else if (s.weighted)
                    for (int j = 0; j < n; ++j)
                        rays[lanes[j]].throughput *=
                            interfaceResponse(lens, indices_, s.surface, s.direction, cosines[j]).reflectance();
                for (int j = 0; j < n; ++j) {
                    Ray& r = rays[lanes[j]].ray;
                    r.direction = glm::normalize(reflect(r.direction, normals[j]));
                }
                return;
            }
            int m = 0;
            const double eta = s.n1 / s.n2;
            for (int j = 0; j < n; ++j) {
                const int i = lanes[j];
                if (margins) {
                    // The test refract() makes, as a margin: sin²θt − 1.
                    const double tir = eta * eta * std::max(0.0, 1.0 - cosines[j] * cosines[j]) - 1.0;
                    out[i].margin = std::max(out[i].margin, tir);
                }
                glm::dvec3 refracted;
                if (!refract(rays[i].ray.direction, normals[j], s.n1, s.n2, &refracted)) {
                    kill(i, TraceStatus::TotalInternalReflection, margins ? std::max(out[i].margin, 0.0) : kUndefined);
                    continue;
                }
                rays[i].ray.direction = refracted;
                cosines[m] = cosines[j];
                lanes[m++] = i;
            }
            if (s.weighted && tables_)
                for (int j = 0; j < m; ++j)
                    rays[lanes[j]].throughput *= tables_->transmittance(s.surface, s.direction, cosines[j]);
            else if (s.weighted)
                for (int j = 0; j < m; ++j)
                    rays[lanes[j]].throughput *=
                        interfaceResponse(lens, indices_, s.surface, s.direction, cosines[j]).transmittance();
            return;
        }
    }
}

}  // namespace flare
