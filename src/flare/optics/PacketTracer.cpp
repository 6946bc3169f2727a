#include "flare/optics/PacketTracer.h"

#include <algorithm>
#include <cstddef>
#include <utility>

#include "flare/optics/Fresnel.h"

namespace flare {

const char* PacketTracer::targetName() { return detail::packetTargetName(); }

PacketTracer::PacketTracer(const BundleTracer& path) : path_(path) {
    using Kind = BundleTracer::Step::Kind;
    const LensSystem& lens = *path_.lens_;
    for (const BundleTracer::Step& bs : path_.steps_) {
        detail::PacketStep s;
        s.surface = bs.surface;
        s.direction = bs.direction;
        switch (bs.kind) {
            case Kind::WrongExit: s.kind = detail::PacketStep::Kind::WrongExit; break;
            case Kind::SensorEnd:
            case Kind::SensorWrongExit:
            case Kind::SensorReflect:
                s.kind = detail::PacketStep::Kind::Sensor;
                s.wrongExit = bs.kind == Kind::SensorWrongExit;
                s.reflect = bs.kind == Kind::SensorReflect;
                s.sensorWeighted = path_.fresnelWeights_;
                s.sensorZMm = lens.sensorZMm();
                s.halfWidthMm = 0.5 * lens.sensor().widthMm;
                s.halfHeightMm = 0.5 * lens.sensor().heightMm;
                s.sensorReflectance = lens.sensor().reflectance;
                break;
            case Kind::Stop:
            case Kind::Refract:
            case Kind::Reflect: {
                const Surface& surface = lens.surface(bs.surface);
                if (surface.hasPolynomial() && bs.kind == Kind::Stop) {
                    s.kind = detail::PacketStep::Kind::Scalar;
                    break;
                }
                s.polynomial = surface.hasPolynomial();
                for (int m = 0; m < kAsphereTerms; ++m) {
                    s.asphere[m] = surface.asphere[m];
                    s.slopeCoefficient[m] = (m + 2) * surface.asphere[m];
                }
                s.kind = bs.kind == Kind::Stop ? detail::PacketStep::Kind::Stop : detail::PacketStep::Kind::Conic;
                s.reflect = bs.kind == Kind::Reflect;
                s.weighted = bs.kind != Kind::Stop && bs.weighted;
                s.laneWeighted = bs.kind != Kind::Stop && path_.fresnelWeights_;
                if (s.weighted && path_.tables_) {
                    const InterfaceTables::Table& t = path_.tables_->table(bs.surface, bs.direction, s.reflect);
                    s.tableValue = t.value.data();
                    s.tableSlope = t.slope.data();
                    s.tableIntervals = path_.tables_->intervals_;
                    s.tableExactFrom = t.exactFrom;
                    s.tableExactTo = t.exactTo;
                }
                s.vertexZMm = surface.vertexZMm;
                s.curvaturePerMm = surface.curvature();
                s.conicFactor = 1.0 + surface.conic;
                s.radiusMm = surface.radiusMm;
                s.centreZMm = surface.vertexZMm + surface.radiusMm;
                s.aperture2Mm2 = surface.semiApertureMm * surface.semiApertureMm;
                s.inverseAperture2PerMm2 = 1.0 / s.aperture2Mm2;
                s.eta = bs.n1 / bs.n2;
                s.normal = s.polynomial                ? detail::PacketStep::Normal::Conic
                           : surface.radiusMm == 0.0   ? detail::PacketStep::Normal::Plane
                           : surface.conic == 0.0      ? detail::PacketStep::Normal::Sphere
                                                       : detail::PacketStep::Normal::Conic;
                const Iris& iris = lens.iris();
                s.roundIris = iris.blades() == 0;
                s.irisInner2Mm2 = s.roundIris ? iris.radiusMm() * iris.radiusMm() : iris.apothemMm() * iris.apothemMm();
                s.irisOuter2Mm2 = iris.circumradiusMm() * iris.circumradiusMm();
                s.blades = iris.blades();
                for (int k = 0; k < std::min(s.blades, detail::PacketStep::kLaneBlades); ++k) {
                    s.edgeNormalX[k] = iris.edgeNormalX(k);
                    s.edgeNormalY[k] = iris.edgeNormalY(k);
                }
                s.apothemMm = iris.apothemMm();
                s.arcCentreMm = iris.arcCentreMm();
                s.arcRadiusMm = iris.arcRadiusMm();
                break;
            }
        }
        steps_.push_back(s);
    }
}

namespace {

// BundleTracer's own step for the listed rays of a batch (all going), written back into the lanes
// (with their margins when asked); returns how many are still going.
int scalarStep(const BundleTracer& path, int step, detail::PacketLanes& b, const int* which, int count,
               bool margins = false) {
    BundleRay rays[detail::kPacketBatch];
    StepOutcome outcomes[detail::kPacketBatch];
    for (int j = 0; j < count; ++j) {
        const int i = which[j];
        rays[j] = {{{b.ox[i], b.oy[i], b.oz[i]}, {b.dx[i], b.dy[i], b.dz[i]}}, b.throughput[i]};
    }
    path.advance(step, std::span<BundleRay>(rays, count), std::span<StepOutcome>(outcomes, count), margins);
    int going = 0;
    for (int j = 0; j < count; ++j) {
        const int i = which[j];
        if (margins) b.margin[i] = outcomes[j].margin;
        if (!outcomes[j].alive) {
            b.fate[i] = detail::fateCode(step, outcomes[j].failure);
            continue;
        }
        ++going;
        const Ray& r = rays[j].ray;
        b.ox[i] = r.originMm.x, b.oy[i] = r.originMm.y, b.oz[i] = r.originMm.z;
        b.dx[i] = r.direction.x, b.dy[i] = r.direction.y, b.dz[i] = r.direction.z;
        b.throughput[i] = rays[j].throughput;
    }
    return going;
}

// Once a quarter of a batch's `active` lanes have ended, moves the `going` ones to the front (their
// inputs in `index` with them) and pads with ended lanes to whole vectors, after `leave(i)` for
// each lane that ended; returns the lanes now active (unchanged if it did not compact).
template <class Leave>
int compactLanes(detail::PacketLanes& b, int* index, int active, int going, Leave&& leave) {
    constexpr int kLanes = detail::kPacketMaxLanes;
    const int needed = (going + kLanes - 1) / kLanes * kLanes;
    if (4 * needed > 3 * active) return active;
    int m = 0;
    for (int i = 0; i < active; ++i) {
        if (b.fate[i] != 0.0) {
            leave(i);
            continue;
        }
        b.ox[m] = b.ox[i], b.oy[m] = b.oy[i], b.oz[m] = b.oz[i];
        b.dx[m] = b.dx[i], b.dy[m] = b.dy[i], b.dz[m] = b.dz[i];
        b.throughput[m] = b.throughput[i];
        b.fate[m] = 0.0;
        index[m++] = index[i];
    }
    for (; m < needed; ++m) {
        b.fate[m] = 1.0;
        index[m] = -1;
    }
    return needed;
}

}  // namespace

void PacketTracer::scalarWeights(const detail::PacketStep& s, detail::PacketLanes& b, int active) const {
    // BundleTracer's factors, one ray at a time (deferred rays get theirs in the scalar step).
    const InterfaceTables* tables = path_.tables_;
    for (int i = 0; i < active; ++i) {
        if (b.scalarWeight[i] == 0.0) continue;
        const double c = b.cosine[i];
        if (tables) {
            b.throughput[i] *= s.reflect ? tables->reflectance(s.surface, s.direction, c)
                                         : tables->transmittance(s.surface, s.direction, c);
        } else {
            const FresnelTerms f = interfaceResponse(*path_.lens_, path_.indices_, s.surface, s.direction, c);
            b.throughput[i] *= s.reflect ? f.reflectance() : f.transmittance();
        }
    }
}

int PacketTracer::runStep(int step, detail::PacketLanes& b, int active, bool margins) const {
    using Kind = detail::PacketStep::Kind;
    const detail::PacketStep& s = steps_[step];
    int which[detail::kPacketBatch];
    int n = 0;
    // BundleTracer's step for every going ray: aspheric iris planes, and, when margins are asked,
    // the sensor (its rectangle's margin), a wrong exit and an iris with more blades than the
    // lanes hold.
    if (s.kind == Kind::Scalar ||
        (margins && (s.kind == Kind::Sensor || s.kind == Kind::WrongExit ||
                     (s.kind == Kind::Stop && s.blades > detail::PacketStep::kLaneBlades)))) {
        for (int i = 0; i < active; ++i)
            if (b.fate[i] == 0.0) which[n++] = i;
        return scalarStep(path_, step, b, which, n, margins);
    }
    if (s.kind == Kind::WrongExit) {  // every going ray ends here
        for (int i = 0; i < active; ++i)
            if (b.fate[i] == 0.0) b.fate[i] = detail::fateCode(step, TraceStatus::WrongExit);
        return 0;
    }
    const detail::PacketStepResult result = detail::advancePacket(
        s, step, b, static_cast<size_t>(active), margins ? detail::PacketMargins::All : detail::PacketMargins::None, false);
    int going = result.going;
    if (result.left & detail::kScalarWeights) scalarWeights(s, b, active);
    if (result.left & detail::kDeferredRays) {
        for (int i = 0; i < active; ++i)
            if (b.deferred[i] != 0.0) which[n++] = i;
        going += scalarStep(path_, step, b, which, n, margins);
    }
    return going;
}

void PacketTracer::advance(int first, int last, std::span<BundleRay> rays, std::span<End> ends,
                           std::span<double* const> margins) const {
    constexpr int kLanes = detail::kPacketMaxLanes;
    const bool withMargins = !margins.empty();
    detail::PacketLanes b;
    int index[detail::kPacketBatch];  // the ray in each lane, −1 for padding
    for (size_t begin = 0; begin < rays.size(); begin += detail::kPacketBatch) {
        const int count = static_cast<int>(std::min<size_t>(detail::kPacketBatch, rays.size() - begin));
        int active = (count + kLanes - 1) / kLanes * kLanes;
        for (int i = 0; i < active; ++i) {
            const BundleRay r = i < count ? rays[begin + i] : BundleRay{};
            b.ox[i] = r.ray.originMm.x, b.oy[i] = r.ray.originMm.y, b.oz[i] = r.ray.originMm.z;
            b.dx[i] = r.ray.direction.x, b.dy[i] = r.ray.direction.y, b.dz[i] = r.ray.direction.z;
            b.throughput[i] = r.throughput;
            b.fate[i] = i < count ? 0.0 : 1.0;  // padding lanes never run
            index[i] = i < count ? static_cast<int>(begin) + i : -1;
        }
        // A lane leaving the batch: its ray's new state, or where it ended.
        auto leave = [&](int i) {
            if (index[i] < 0) return;
            if (b.fate[i] == 0.0) {
                BundleRay& r = rays[index[i]];
                r.ray.originMm = {b.ox[i], b.oy[i], b.oz[i]};
                r.ray.direction = {b.dx[i], b.dy[i], b.dz[i]};
                r.throughput = b.throughput[i];
                ends[index[i]] = End{};
                return;
            }
            const int code = static_cast<int>(b.fate[i]) - 1;
            ends[index[i]] = End{code / 8, static_cast<TraceStatus>(code % 8)};
        };
        for (int step = first; step <= last; ++step) {
            const int going = runStep(step, b, active, withMargins);
            if (withMargins) {
                // The rays that entered this step: going on, or ended here.
                const double endedHere = detail::fateCode(step, TraceStatus::Ok);
                for (int i = 0; i < active; ++i)
                    if (index[i] >= 0 && (b.fate[i] == 0.0 || (b.fate[i] >= endedHere && b.fate[i] < endedHere + 8.0)))
                        margins[index[i]][step] = b.margin[i];
            }
            // Once a quarter of the lanes have ended, the going ones move together (as trace()).
            active = compactLanes(b, index, active, going, leave);
        }
        for (int i = 0; i < active; ++i) leave(i);
    }
}

int PacketTracer::runStepOwnIndices(int step, detail::PacketLanes& b, int active, const int* index,
                                    std::span<const SpectralIndices* const> indices) const {
    using Kind = detail::PacketStep::Kind;
    const detail::PacketStep& s = steps_[step];
    // Steps that do not refract or weigh do not depend on the wavelength: runStep's own.
    if (s.kind != Kind::Conic) return runStep(step, b, active, false);
    const int k = s.surface;
    // The lane's n1 and n2 as tracePath takes them.
    auto media = [&](int i) {
        const SpectralIndices& n = *indices[index[i]];
        return s.direction > 0 ? std::pair{n.n[k], n.n[k + 1]} : std::pair{n.n[k + 1], n.n[k]};
    };
    if (!s.reflect)
        for (int i = 0; i < active; ++i) {
            if (b.fate[i] != 0.0) continue;
            const auto [n1, n2] = media(i);
            b.eta[i] = n1 / n2;
        }
    const detail::PacketStepResult result =
        detail::advancePacket(s, step, b, static_cast<size_t>(active), detail::PacketMargins::None, true);
    if (result.left & detail::kScalarWeights) {
        for (int i = 0; i < active; ++i) {
            if (b.scalarWeight[i] == 0.0) continue;
            const auto [n1, n2] = media(i);
            if (!s.reflect && n1 == n2) continue;  // (tracePath weighs no refraction between equal indices)
            const FresnelTerms f = interfaceResponse(*path_.lens_, *indices[index[i]], k, s.direction, b.cosine[i]);
            b.throughput[i] *= s.reflect ? f.reflectance() : f.transmittance();
        }
    }
    int going = result.going;
    if (result.left & detail::kDeferredRays)
        for (int i = 0; i < active; ++i)
            if (b.deferred[i] != 0.0) b.fate[i] = detail::retraceCode(step);
    return going;
}

template <bool kOwnIndices, class RayAt>
void PacketTracer::traceRays(size_t count, const RayAt& rayAt, std::span<const SpectralIndices* const> indices,
                             std::span<BundleLanding> out) const {
    constexpr int kLanes = detail::kPacketMaxLanes;
    detail::PacketLanes b;
    int index[detail::kPacketBatch];  // the input of each lane, −1 for padding
    const LensSystem& lens = *path_.lens_;
    std::vector<int> retrace;  // (own indices) rays left to the scalar code at a refraction
    for (size_t begin = 0; begin < count; begin += detail::kPacketBatch) {
        const int batch = static_cast<int>(std::min<size_t>(detail::kPacketBatch, count - begin));
        int active = (batch + kLanes - 1) / kLanes * kLanes;  // lanes in use, whole vectors
        for (int i = 0; i < active; ++i) {
            const Ray r = i < batch ? rayAt(begin + i) : Ray{};
            b.ox[i] = r.originMm.x, b.oy[i] = r.originMm.y, b.oz[i] = r.originMm.z;
            b.dx[i] = r.direction.x, b.dy[i] = r.direction.y, b.dz[i] = r.direction.z;
            b.throughput[i] = 1.0;
            b.fate[i] = i < batch ? 0.0 : 1.0;  // padding lanes never run
            if constexpr (kOwnIndices) b.eta[i] = 1.0;
            index[i] = i < batch ? static_cast<int>(begin) + i : -1;
        }
        auto land = [&](int i) {
            if (index[i] < 0) return;
            BundleLanding& o = out[index[i]];
            o = BundleLanding{};
            if (b.fate[i] == 0.0) {
                o.sensorMm = {b.ox[i], b.oy[i]};
                o.throughput = b.throughput[i];
                o.status = TraceStatus::Ok;
                o.surface = lens.surfaceCount();
                return;
            }
            const int code = static_cast<int>(b.fate[i]) - 1;
            if (kOwnIndices && code % 8 == detail::kRetraceStatus) {
                retrace.push_back(index[i]);
                return;
            }
            o.status = static_cast<TraceStatus>(code % 8);
            o.surface = path_.stepSurface(code / 8);
        };
        for (int step = 0; step < static_cast<int>(steps_.size()); ++step) {
            int going;
            if constexpr (kOwnIndices) going = runStepOwnIndices(step, b, active, index, indices);
            else going = runStep(step, b, active, false);
            // A ghost path loses most rays within a few steps: once a quarter of the lanes are
            // dead, the ended rays land and the going ones move together, so that later steps
            // run fewer vectors (moving a ray costs far less than a step).
            active = compactLanes(b, index, active, going, land);
        }
        for (int i = 0; i < active; ++i) land(i);
    }
    if (!kOwnIndices || retrace.empty()) return;
    SequentialPath path;
    path.reflections = path_.reflections();
    TraceOptions options;
    options.fresnelWeights = path_.fresnelWeights_;
    for (const int j : retrace) {
        const TraceResult r = tracePath(lens, *indices[j], rayAt(static_cast<size_t>(j)), path, options);
        BundleLanding& o = out[j];
        o = BundleLanding{};
        o.status = r.status;
        o.surface = r.surface;
        o.throughput = r.throughput;
        if (r.ok()) o.sensorMm = {r.ray.originMm.x, r.ray.originMm.y};
    }
}

void PacketTracer::trace(const PupilGrid& grid, std::span<const glm::dvec2> pupilMm, std::span<BundleLanding> out) const {
    traceRays<false>(pupilMm.size(), [&](size_t i) { return grid.ray(pupilMm[i].x, pupilMm[i].y); }, {}, out);
}

void PacketTracer::trace(std::span<const Ray> rays, std::span<const SpectralIndices* const> indices,
                         std::span<BundleLanding> out) const {
    traceRays<true>(rays.size(), [&](size_t i) { return rays[i]; }, indices, out);
}

}  // namespace flare
