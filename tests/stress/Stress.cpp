#include "Stress.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <sstream>

#include <glm/geometric.hpp>

#include "RandomLens.h"
#include "flare/core/Error.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/RealRays.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/photons/PhotonTracer.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"

namespace flare::stress {

namespace {

constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
constexpr double kDegToRad = std::numbers::pi / 180.0;
constexpr int kMaxFailuresKept = 50;
constexpr double kNewtonTolerance = 1e-12;
constexpr double kGrazingCosine = 1e-6;  // Surface.cpp: Newton stops at |step| < 1e-12 (1 + |t|)

std::string hex(double v) {
    char buffer[48];
    std::snprintf(buffer, sizeof buffer, "%a", v);
    return buffer;
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Digits become '#', so that messages differing only in numbers count together.
std::string canonical(const std::string& problem) {
    std::string out;
    for (char c : problem) {
        if (out.size() >= 70) break;
        const bool digit = std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == 'e';
        if (std::isdigit(static_cast<unsigned char>(c))) {
            if (out.empty() || out.back() != '#') out += '#';
        } else if (digit && !out.empty() && out.back() == '#') {
            continue;  // part of a number
        } else {
            out += c;
        }
    }
    return out;
}

// ---- Rays -----------------------------------------------------------------------------------------

glm::dvec3 direction(double theta, double psi) {
    return {std::sin(theta) * std::cos(psi), std::sin(theta) * std::sin(psi), std::cos(theta)};
}

// A point of surface s at radius r (pulled in until the surface exists there), azimuth phi.
glm::dvec3 pointOn(const Surface& s, double r, double phi) {
    double sag = 0.0;
    while (!s.sagMm(r * r, &sag) && r > 0.0) r *= 0.999;
    return {r * std::cos(phi), r * std::sin(phi), s.vertexZMm + sag};
}

double edgeRadius(const LensSystem& lens, int k) {
    const Surface& s = lens.surface(k);
    return s.isStop ? lens.iris().circumradiusMm() : s.semiApertureMm;
}

// Kinds of object-space rays, shared by the sequential and the photon tracer.
enum class ObjectRay { Axial, Field, Grazing, FrontEdge, Count };

// A ray that meets the first surface's (extended) shape at P with direction d, started in front of
// every point of the first surface.
Ray objectSpaceRay(ObjectRay kind, const LensSystem& lens, Rng& rng) {
    const double zFront = objectSpaceStartZMm(lens);
    if (kind == ObjectRay::Axial) return {{0.0, 0.0, zFront}, {0.0, 0.0, 1.0}};
    const Surface& s0 = lens.surface(0);
    const double edge = edgeRadius(lens, 0);
    const double psi = uniform(rng, 0.0, 2.0 * std::numbers::pi), phi = uniform(rng, 0.0, 2.0 * std::numbers::pi);
    glm::dvec3 p, d;
    switch (kind) {
        case ObjectRay::Field: {
            p = pointOn(s0, 1.1 * edge * std::sqrt(rng.uniform()), phi);
            const double maxDeg = chance(rng, 0.2) ? 89.9 : 60.0;
            d = direction(uniform(rng, 0.0, maxDeg) * kDegToRad, psi);
            break;
        }
        case ObjectRay::Grazing: {
            p = pointOn(s0, edge * std::sqrt(rng.uniform()), phi);
            d = direction(0.5 * std::numbers::pi - logUniform(rng, -10.0, -1.0), psi);
            break;
        }
        default: {  // FrontEdge: just inside or just outside the clear aperture (or the iris)
            const double offset = (chance(rng, 0.5) ? 1.0 : -1.0) * logUniform(rng, -15.0, -3.0);
            p = pointOn(s0, edge * (1.0 + offset), phi);
            d = direction(uniform(rng, 0.0, 30.0) * kDegToRad, psi);
            break;
        }
    }
    const double back = (p.z - zFront) / d.z + 1.0;
    return {p - back * d, d};
}

// ---- Checks ---------------------------------------------------------------------------------------

enum class Expect { Finite, Tir, Refract, OnAxis, Reversible };

const char* toString(Expect e) {
    switch (e) {
        case Expect::Finite: return "finite";
        case Expect::Tir: return "tir";
        case Expect::Refract: return "refract";
        case Expect::OnAxis: return "axis";
        case Expect::Reversible: return "reversible";
    }
    return "?";
}

struct SequentialCase {
    Ray ray;
    int start = -1, direction = 1;
    SequentialPath::End end = SequentialPath::End::Sensor;
    std::vector<int> reflections;
    bool clip = true;
    Expect expect = Expect::Finite;
    int surface = -1;  // Tir / Refract: the surface concerned
};

// Invariants of every trace result; "" when they hold.
std::string traceProblem(const LensSystem& lens, const TraceResult& r) {
    const int n = lens.surfaceCount();
    if (!finite(r.ray.originMm) || !finite(r.ray.direction))
        return "non-finite ray in the trace result (status " + std::string(toString(r.status)) + ")";
    if (!std::isfinite(r.throughput))
        return "non-finite throughput " + hex(r.throughput) + " (status " + std::string(toString(r.status)) + ")";
    if (r.throughput < 0.0 || r.throughput > 1.0 + 1e-9) return "throughput " + hex(r.throughput) + " outside [0, 1]";
    if (!r.ok() && r.throughput != 0.0) return "a failed trace kept throughput";
    if (r.surface < -1 || r.surface > n) return "end surface " + std::to_string(r.surface) + " out of range";
    if (r.interactions < 0) return "negative interaction count";
    if (r.ok() && std::abs(glm::length(r.ray.direction) - 1.0) > 1e-9) return "direction not of unit length";
    if (r.ok() && r.surface == n &&
        std::abs(r.ray.originMm.z - lens.sensorZMm()) > 1e-9 * std::max(1.0, std::abs(lens.sensorZMm())))
        return "arrived off the sensor plane";
    return "";
}

struct ReversalOutcome {
    enum Kind { NotApplicable, Compared, NotReturned, IllConditioned, NotSequential } kind = NotApplicable;
    double ratio = 0.0;  // error / (m ε (S + κ))
};

// Forward without clipping, then the arriving ray reversed and traced back: it must come back to
// the point where it met the first surface, travelling against its initial direction.
ReversalOutcome reversal(const LensSystem& lens, const SpectralIndices& indices, const Ray& ray, std::string* problem) {
    ReversalOutcome out;
    TraceOptions options;
    options.clipApertures = false;
    std::vector<glm::dvec3> points;
    options.pathPointsMm = &points;
    const TraceResult forward = traceForward(lens, indices, ray, options);
    if (std::string p = traceProblem(lens, forward); !p.empty()) {
        *problem = "forward (unclipped): " + p;
        return out;
    }
    if (!forward.ok() || points.size() < 2) return out;
    options.pathPointsMm = nullptr;
    // A sequential trace meets only the next surface: a segment that crosses another surface on
    // the way (possible where a steep surface curls back, or beyond a clear aperture, since the
    // trace is unclipped) is not a physical path and cannot be retraced. Only paths where each
    // point is also the first hit when looking back from the next one are compared.
    double scale = 0.0;
    for (const glm::dvec3& p : points) scale = std::max({scale, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    for (size_t i = 1; i + 1 < points.size(); ++i) {
        const glm::dvec3 segment = points[i + 1] - points[i];
        const double length = glm::length(segment);
        if (!(length > 0.0)) continue;
        const SurfaceHit hit = intersect(lens.surface(static_cast<int>(i) - 1), Ray{points[i + 1], -segment / length});
        const double local = glm::length(points[i]) + glm::length(points[i + 1]);
        if (hit.status != HitStatus::Hit || std::abs(hit.tMm - length) > 1e-6 * local) {
            out.kind = ReversalOutcome::NotSequential;
            return out;
        }
    }
    // Within 1e-6 of grazing (incidence or exit, at any event) the first-order error model below
    // fails: the outgoing cosine is √(cos²), and once cos² is within a few hundred ε of zero its
    // rounding error is not small against it, so errors grow as √ε, not ε. Such rays are counted
    // as ill-conditioned and not compared.
    for (size_t i = 1; i + 1 < points.size() && i <= static_cast<size_t>(lens.surfaceCount()); ++i) {
        const Surface& s = lens.surface(static_cast<int>(i) - 1);
        if (s.isStop) continue;
        const glm::dvec3 normal = s.normalAt(points[i]);
        const double cosIn = std::abs(glm::dot(normal, glm::normalize(points[i] - points[i - 1])));
        const double cosOut = std::abs(glm::dot(normal, glm::normalize(points[i + 1] - points[i])));
        if (std::min(cosIn, cosOut) < kGrazingCosine) {
            out.kind = ReversalOutcome::IllConditioned;
            return out;
        }
    }
    const Ray reversed{forward.ray.originMm, -forward.ray.direction};
    std::vector<glm::dvec3> backPoints;
    options.pathPointsMm = &backPoints;
    const TraceResult back = traceBackward(lens, indices, reversed, options);
    options.pathPointsMm = nullptr;
    if (std::string p = traceProblem(lens, back); !p.empty()) {
        *problem = "reversed: " + p;
        return out;
    }
    if (!back.ok()) {
        out.kind = ReversalOutcome::NotReturned;
        return out;
    }
    // Amplification of the rounding errors made at each event of the reversed trace on the way
    // back to the start: the reversed trace is restarted from every event it made (the reversed
    // ray at the sensor, then each surface it met) with the position moved by ±h·S and the
    // direction by ±h, h = 1024 ε (just above rounding size, so that the differences stay linear
    // even next to grazing incidence and the critical angle, where the response grows as 1/cos θ).
    // Rounding errors of ε·S and ε made there then move the result by about (ε/h)·|Δ|. (The whole
    // backward map from the sensor alone is not enough: an error made inside the lens can meet an
    // expanding refraction that the earlier, contracting ones hide.) Forward errors are covered by
    // the same bound: an error made at forward event k is undone by the reversed trace up to event
    // k and then carried back to the start like an error made there.
    const double h = 1024.0 * kEpsilon;
    const int n = lens.surfaceCount();
    double ampPosition = 0.0, ampDirection = 0.0;
    for (size_t j = 0; j + 1 < backPoints.size(); ++j) {
        const glm::dvec3 segment = backPoints[j + 1] - backPoints[j];
        if (!(glm::length(segment) > 0.0)) continue;
        const Ray from{backPoints[j], j == 0 ? reversed.direction : glm::normalize(segment)};
        SequentialPath path;
        path.start = n - static_cast<int>(j);
        path.direction = -1;
        path.end = SequentialPath::End::ObjectSpace;
        for (int i = 0; i < 8; ++i) {
            Ray perturbed = from;
            const double sign = i < 4 ? 1.0 : -1.0;
            if (i % 4 == 0) perturbed.originMm.x += sign * h * scale;
            if (i % 4 == 1) perturbed.originMm.y += sign * h * scale;
            if (i % 4 == 2) perturbed.direction = glm::normalize(perturbed.direction + glm::dvec3(sign * h, 0.0, 0.0));
            if (i % 4 == 3) perturbed.direction = glm::normalize(perturbed.direction + glm::dvec3(0.0, sign * h, 0.0));
            const TraceResult moved = tracePath(lens, indices, perturbed, path, options);
            if (!moved.ok()) {
                out.kind = ReversalOutcome::IllConditioned;
                return out;
            }
            ampPosition = std::max(ampPosition, glm::length(moved.ray.originMm - back.ray.originMm) / h);
            ampDirection = std::max(ampDirection, glm::length(moved.ray.direction - back.ray.direction) / h);
        }
    }
    // Spheres, conics and planes are solved in closed form (rounding only); aspheres by Newton's
    // method, which stops once a step is below 1e-12 (1 + |t|) (Surface.cpp): on a path through an
    // asphere that, not ε, bounds the relative error of an event.
    bool asphere = false;
    for (int k = 0; k < lens.surfaceCount(); ++k) asphere |= lens.surface(k).hasPolynomial();
    const double epsilon = asphere ? std::max(kEpsilon, kNewtonTolerance * (1.0 + scale) / scale) : kEpsilon;
    const double m = forward.interactions + back.interactions;
    const double errorPosition = glm::length(back.ray.originMm - points[1]);
    const double errorDirection = glm::length(back.ray.direction + ray.direction);
    // An intersection from an origin far away (grazing rays start up to 10¹¹ mm out; a steep exit
    // ray may reach the sensor far off the axis) is solved from the ray's point closest to the
    // vertex, o′ (intersectConic, when |c cc| > kConicFarOrigin² with cc the conic's value at o;
    // o: origin relative to the vertex, c: curvature): the rounding of that point, ε |o|, and the
    // quadratic's cancellation from it, ε |o′|² |c|, put the hit point off the surface by up to
    // e = ε (|o| + |o′|² |c|) / cos θ (from a nearer origin, e = ε |o|² |c| / cos θ, at most a few
    // ε |o| / cos θ). At the forward trace's first surface the reversed ray,
    // meeting the surface itself, sees that as a position error e and a normal (so direction) error
    // e |c| at the start. At the reversed trace's first surface (the last one) the same errors are
    // carried back like any other (the amplifications above, per unit of position and of direction).
    auto farHitError = [&](int k, const Ray& r, const glm::dvec3& hit, double* curvature) {
        const Surface& surface = lens.surface(k);
        *curvature = std::abs(surface.curvature()) * std::max(1.0, std::abs(1.0 + surface.conic));
        if (surface.hasPolynomial()) return 0.0;  // polished by Newton's method
        const glm::dvec3 o = r.originMm - glm::dvec3(0.0, 0.0, surface.vertexZMm);
        const glm::dvec3 nearest = o - glm::dot(o, r.direction) * r.direction;
        const double distance = glm::length(o);
        const double c = surface.curvature(), k1 = 1.0 + surface.conic;
        const double cc = c * (o.x * o.x + o.y * o.y + k1 * o.z * o.z) - 2.0 * o.z;
        const double solved = std::abs(c * cc) > kConicFarOrigin * kConicFarOrigin
                                  ? distance + glm::dot(nearest, nearest) * *curvature
                                  : distance * distance * *curvature;
        const double cosTheta = std::max(kGrazingCosine, std::abs(glm::dot(surface.normalAt(hit), r.direction)));
        return kEpsilon * solved / cosTheta;
    };
    double cFirst = 0.0, cLast = 0.0;
    const double eFirst = farHitError(0, ray, points[1], &cFirst);
    const double eLast = backPoints.size() > 1 ? farHitError(n - 1, reversed, backPoints[1], &cLast) : 0.0;
    const double carried = eLast * (1.0 / scale + cLast);
    const double budgetPosition = m * epsilon * (scale + ampPosition) + eFirst + ampPosition * carried;
    const double budgetDirection = m * epsilon * (1.0 + ampDirection) + eFirst * cFirst + ampDirection * carried;
    const double ratio = std::max(errorPosition / budgetPosition, errorDirection / budgetDirection);
    out.kind = ReversalOutcome::Compared;
    out.ratio = ratio;
    if (!(ratio <= kReversalSafety))
        *problem = "forward-then-reversed ray misses its start by " + hex(errorPosition) + " mm / " + hex(errorDirection) +
                   " (ratio " + std::to_string(ratio) + " > " + std::to_string(kReversalSafety) + ")";
    return out;
}

// Runs one sequential case; "" if every check holds.
std::string runCase(const LensSystem& lens, const SpectralIndices& indices, const SequentialCase& c,
                    TraceResult* result, ReversalOutcome* reversalOut) {
    SequentialPath path;
    path.start = c.start;
    path.direction = c.direction;
    path.end = c.end;
    path.reflections = c.reflections;
    TraceOptions options;
    options.clipApertures = c.clip;
    *result = tracePath(lens, indices, c.ray, path, options);
    if (std::string p = traceProblem(lens, *result); !p.empty()) return p;
    switch (c.expect) {
        case Expect::Finite: break;
        case Expect::Tir:
            if (!(result->status == TraceStatus::TotalInternalReflection && result->surface == c.surface))
                return "beyond the critical angle at surface " + std::to_string(c.surface) + " but ended " +
                       toString(result->status) + " at " + std::to_string(result->surface);
            break;
        case Expect::Refract:
            if (result->status == TraceStatus::TotalInternalReflection && result->surface == c.surface)
                return "below the critical angle at surface " + std::to_string(c.surface) + " but totally reflected";
            break;
        case Expect::OnAxis:
            if (result->ok() && (result->ray.originMm.x != 0.0 || result->ray.originMm.y != 0.0 ||
                                 result->ray.direction.x != 0.0 || result->ray.direction.y != 0.0))
                return "an axial ray left the axis";
            break;
        case Expect::Reversible: {
            std::string problem;
            *reversalOut = reversal(lens, indices, c.ray, &problem);
            if (!problem.empty()) return problem;
            break;
        }
    }
    return "";
}

struct PhotonCase {
    Ray ray;
    double wavelengthNm = 550.0;
    InteriorMaterials materials;
    int maxBounces = -1;
    std::uint64_t rngSeed = 0, rngStream = 0;
};

// Invariants of one traced photon; "" if they hold. Lost and EventLimit are reported separately.
std::string photonProblem(const LensSystem& lens, const PhotonCase& c, const PhotonHistory& h) {
    if (static_cast<int>(h.fate) < 0 || h.fate >= PhotonFate::Count) return "invalid fate";
    if (h.arrivalCount < 0 || h.arrivalCount > kMaxSensorArrivals) return "arrival count out of range";
    const double halfW = 0.5 * lens.sensor().widthMm, halfH = 0.5 * lens.sensor().heightMm;
    for (int i = 0; i < h.arrivalCount; ++i) {
        const glm::dvec2& p = h.arrivals[i].positionMm;
        if (!std::isfinite(p.x) || !std::isfinite(p.y)) return "non-finite sensor arrival";
        if (std::abs(p.x) > halfW || std::abs(p.y) > halfH) return "arrival outside the sensor";
        if (h.arrivals[i].scattered && h.scatters == 0) return "arrival marked scattered without a scatter";
    }
    if (h.fate == PhotonFate::AbsorbedSensor && h.arrivalCount == 0) return "absorbed by the sensor without arriving";
    if (h.events > kMaxPhotonEvents || h.reflections < 0 || h.scatters < 0) return "event counts out of range";
    if (c.maxBounces >= 0 && h.reflections > c.maxBounces) return "more reflections than the bounce limit";
    if (c.maxBounces < 0 && h.fate == PhotonFate::BounceLimit) return "bounce limit without a limit";
    const InteriorMaterials& m = c.materials;
    if ((m.housingAlbedo >= 1.0 && h.fate == PhotonFate::AbsorbedHousing) ||
        (m.edgeAlbedo >= 1.0 && h.fate == PhotonFate::AbsorbedEdge) ||
        (m.irisAlbedo >= 1.0 && h.fate == PhotonFate::AbsorbedIris))
        return std::string("absorbed by a white wall (") + toString(h.fate) + ")";
    if ((m.housingAlbedo == 0.0 && m.edgeAlbedo == 0.0 && m.irisAlbedo == 0.0) && h.scatters > 0)
        return "scattered off a black interior";
    return "";
}

void tracePhoton(const LensSystem& lens, const PhotonCase& c, PhotonHistory& h) {
    const PhotonTracer tracer(lens, c.materials, c.maxBounces);
    Rng rng(c.rngSeed, c.rngStream);
    tracer.trace(lens.indicesAt(c.wavelengthNm), c.ray, rng, h);
}

// ---- Reproducers ----------------------------------------------------------------------------------

std::string rayLine(const Ray& r) {
    return hex(r.originMm.x) + " " + hex(r.originMm.y) + " " + hex(r.originMm.z) + " " + hex(r.direction.x) + " " +
           hex(r.direction.y) + " " + hex(r.direction.z);
}

std::string reproducerHeader(const std::string& problem) {
    return "#! problem " + problem + "\n";
}

std::string sequentialReproducer(const SequentialCase& c, double wavelengthNm) {
    std::string s = "#! check sequential\n#! wavelength_nm " + hex(wavelengthNm) + "\n#! ray " + rayLine(c.ray) + "\n";
    s += "#! path " + std::to_string(c.start) + " " + std::to_string(c.direction) + " " +
         (c.end == SequentialPath::End::Sensor ? "sensor" : "object");
    for (int r : c.reflections) s += " " + std::to_string(r);
    s += "\n#! clip " + std::to_string(c.clip ? 1 : 0) + "\n#! expect " + toString(c.expect) + " " +
         std::to_string(c.surface) + "\n";
    return s;
}

std::string photonReproducer(const PhotonCase& c) {
    return "#! check photon\n#! wavelength_nm " + hex(c.wavelengthNm) + "\n#! ray " + rayLine(c.ray) + "\n#! photon " +
           std::to_string(c.rngSeed) + " " + std::to_string(c.rngStream) + " " + hex(c.materials.housingAlbedo) + " " +
           hex(c.materials.edgeAlbedo) + " " + hex(c.materials.irisAlbedo) + " " + std::to_string(c.maxBounces) + "\n";
}

struct Context {
    const StressConfig& config;
    StressReport& report;
    int lensIndex = 0;
    const GeneratedLens* lens = nullptr;
    const char* tag = "";  // sequential, photon or render: the reproducer's file name starts with it
    int reproducers = 0;

    // Records a failure with its reproducer (the lens text after a header of "#!" lines, which the
    // lens parser reads as comments).
    void fail(const std::string& what, const std::string& header, bool countAsFailure = true) {
        std::string where = "lens " + std::to_string(lensIndex) + " (seed " + std::to_string(config.seed) + ")";
        std::string file;
        if (!config.reproducerDir.empty() && reproducers < 20 && (countAsFailure || config.findingReproducers)) {
            std::filesystem::create_directories(config.reproducerDir);
            file = config.reproducerDir + "/" + tag + "-seed" + std::to_string(config.seed) + "-lens" +
                   std::to_string(lensIndex) + "-" + std::to_string(reproducers++) + ".lens";
            std::ofstream(file) << reproducerHeader(what) << header << lens->text;
            where += ", reproducer " + file;
        }
        if (countAsFailure && static_cast<int>(report.failures.size()) < kMaxFailuresKept)
            report.failures.push_back(what + " — " + where);
    }
};

// Draws config.lenses lenses (or reads them from config.lensFiles), builds the valid ones and calls
// `body` for each.
void forEachLens(const char* tag, const StressConfig& config, StressReport& report,
                 const std::function<void(Context&, const LensSystem&, Rng&)>& body) {
    for (int i = 0; i < config.lenses; ++i) {
        Rng rng(config.seed, static_cast<std::uint64_t>(i));
        GeneratedLens generated;
        std::string fileName = "random.lens";
        if (config.lensFiles.empty()) {
            generated = randomLens(rng);
        } else {
            fileName = config.lensFiles[static_cast<size_t>(i) % config.lensFiles.size()];
            std::ifstream in(fileName);
            generated.text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        }
        ++report.lensesTried;
        Context context{config, report, i, &generated, tag};
        std::optional<LensSystem> lens;
        try {
            lens = LensSystem::build(parseLensText(generated.text, fileName));
        } catch (const InputError& e) {
            ++report.lensesRejected;
            ++report.rejections[canonical(e.problem())];
            continue;
        } catch (const std::exception& e) {
            context.fail(std::string("the lens parser threw a non-input error: ") + e.what(), "");
            continue;
        }
        ++report.lensesBuilt;
        body(context, *lens, rng);
    }
}

// Surfaces (and the sensor) where a ghost path may reflect.
std::vector<int> reflectingSurfaces(const LensSystem& lens) {
    std::vector<int> out;
    for (int k = 0; k < lens.surfaceCount(); ++k)
        if (lens.isReflecting(k)) out.push_back(k);
    out.push_back(lens.surfaceCount());
    return out;
}

// A random ghost sequence of order 2 ({b, a}, a < b) or 4 ({b, a, c, d}: a < b, c > a, d < c).
std::vector<int> randomGhost(const std::vector<int>& reflecting, Rng& rng) {
    const int count = static_cast<int>(reflecting.size());
    if (count < 2) return {};
    const int ia = uniformInt(rng, 0, count - 2);
    const int ib = uniformInt(rng, ia + 1, count - 1);
    std::vector<int> path{reflecting[ib], reflecting[ia]};
    if (chance(rng, 0.3)) {
        const int ic = uniformInt(rng, ia + 1, count - 1);
        const int id = uniformInt(rng, 0, ic - 1);
        path.push_back(reflecting[ic]);
        path.push_back(reflecting[id]);
    }
    return path;
}

// The sequential case of kind `kind` (0..7) for this lens.
SequentialCase sequentialCase(int kind, const LensSystem& lens, const SpectralIndices& indices, Rng& rng) {
    const int n = lens.surfaceCount();
    SequentialCase c;
    switch (kind) {
        case 0: c.ray = objectSpaceRay(ObjectRay::Axial, lens, rng); c.expect = Expect::OnAxis; break;
        case 1: c.ray = objectSpaceRay(ObjectRay::Field, lens, rng); c.expect = Expect::Reversible; break;
        case 2: c.ray = objectSpaceRay(ObjectRay::Grazing, lens, rng); c.expect = Expect::Reversible; break;
        case 3: c.ray = objectSpaceRay(ObjectRay::FrontEdge, lens, rng); c.expect = Expect::Reversible; break;
        case 4: {  // a ghost path
            c.ray = objectSpaceRay(static_cast<ObjectRay>(uniformInt(rng, 1, 3)), lens, rng);
            c.reflections = randomGhost(reflectingSurfaces(lens), rng);
            break;
        }
        case 5: {  // at the edge of an inner surface (or of the iris), from just in front of it
            const int k = uniformInt(rng, 0, n - 1);
            const double offset = (chance(rng, 0.5) ? 1.0 : -1.0) * logUniform(rng, -15.0, -3.0);
            const glm::dvec3 p = pointOn(lens.surface(k), edgeRadius(lens, k) * (1.0 + offset), uniform(rng, 0.0, 2.0 * std::numbers::pi));
            const glm::dvec3 d = direction(uniform(rng, 0.0, 20.0) * kDegToRad, uniform(rng, 0.0, 2.0 * std::numbers::pi));
            c.ray = {p - 1e-3 * d, d};
            c.start = k - 1;
            break;
        }
        case 6: {  // at the critical angle of an interface, from the denser side
            std::vector<int> candidates;
            for (int k = 0; k < n; ++k)
                if (!lens.surface(k).isStop && indices.n[k] != indices.n[k + 1]) candidates.push_back(k);
            if (candidates.empty()) return sequentialCase(1, lens, indices, rng);
            const int k = candidates[uniformInt(rng, 0, static_cast<int>(candidates.size()) - 1)];
            const Surface& s = lens.surface(k);
            const bool forward = indices.n[k] > indices.n[k + 1];
            const double n1 = forward ? indices.n[k] : indices.n[k + 1], n2 = forward ? indices.n[k + 1] : indices.n[k];
            const glm::dvec3 p = pointOn(s, 0.98 * s.semiApertureMm * std::sqrt(rng.uniform()), uniform(rng, 0.0, 2.0 * std::numbers::pi));
            const glm::dvec3 normal = s.normalAt(p);
            glm::dvec3 helper = direction(uniform(rng, 0.0, std::numbers::pi), uniform(rng, 0.0, 2.0 * std::numbers::pi));
            glm::dvec3 tangent = helper - glm::dot(helper, normal) * normal;
            if (glm::length(tangent) < 1e-3) tangent = glm::cross(normal, glm::dvec3(1.0, 0.0, 0.0));
            tangent = glm::normalize(tangent);
            const double critical = std::asin(n2 / n1);
            const double v = rng.uniform();
            const double delta = v < 1.0 / 3.0 ? 0.0 : (v < 2.0 / 3.0 ? 1.0 : -1.0) * logUniform(rng, -15.0, -5.0);
            const double theta = std::clamp(critical + delta, 0.0, 0.5 * std::numbers::pi);
            const glm::dvec3 d = glm::normalize((forward ? 1.0 : -1.0) * std::cos(theta) * normal + std::sin(theta) * tangent);
            c.ray = {p - 1e-4 * d, d};
            c.start = forward ? k - 1 : k + 1;
            c.direction = forward ? 1 : -1;
            c.end = forward ? SequentialPath::End::Sensor : SequentialPath::End::ObjectSpace;
            c.surface = k;
            // Only assert where the ray certainly meets surface k at p first.
            const SurfaceHit hit = intersect(s, c.ray);
            const bool meetsP = hit.status == HitStatus::Hit && glm::length(c.ray.at(hit.tMm) - p) < 1e-9 * (1.0 + glm::length(p));
            const double gap = theta - critical;
            if (meetsP && gap > kCriticalAngleMarginRad) c.expect = Expect::Tir;
            if (meetsP && gap < -kCriticalAngleMarginRad) c.expect = Expect::Refract;
            break;
        }
        default: {  // from the sensor backwards, at its corners and edges too
            const double w = lens.sensor().widthMm, h = lens.sensor().heightMm;
            double x = uniform(rng, -0.5, 0.5) * w, y = uniform(rng, -0.5, 0.5) * h;
            if (chance(rng, 0.2)) x = (chance(rng, 0.5) ? 0.5 : -0.5) * w;
            if (chance(rng, 0.2)) y = (chance(rng, 0.5) ? 0.5 : -0.5) * h;
            const bool axial = chance(rng, 0.1);
            const double theta = axial ? 0.0 : chance(rng, 0.2) ? 0.5 * std::numbers::pi - logUniform(rng, -10.0, -1.0)
                                                                : uniform(rng, 0.0, 70.0) * kDegToRad;
            glm::dvec3 d = direction(theta, uniform(rng, 0.0, 2.0 * std::numbers::pi));
            d.z = -d.z;
            c.ray = {{axial ? 0.0 : x, axial ? 0.0 : y, lens.sensorZMm()}, d};
            c.start = n;
            c.direction = -1;
            c.end = SequentialPath::End::ObjectSpace;
            if (axial) c.expect = Expect::OnAxis;
            if (chance(rng, 0.2)) c.reflections = {n > 1 ? uniformInt(rng, 0, n - 1) : 0, n};  // a sensor ghost seen backwards
            if (!c.reflections.empty()) c.end = SequentialPath::End::Sensor;
            break;
        }
    }
    return c;
}

}  // namespace

std::string StressReport::summary() const {
    std::ostringstream s;
    s << "lenses: " << lensesTried << " drawn, " << lensesBuilt << " built, " << lensesRejected << " rejected by the builder\n";
    for (const auto& [why, count] : rejections) s << "  rejected " << count << "x: " << why << "\n";
    if (rays > 0) {
        s << "sequential rays: " << rays << " (" << raysOk << " reached their end)\n";
        for (const auto& [status, count] : statuses) s << "  " << status << ": " << count << "\n";
        s << "reversals: " << reversalsCompared << " compared, worst error " << worstReversalRatio
          << " m·ε·(S+κ) (limit " << kReversalSafety << "); " << reversalsNotReturned << " did not return, "
          << reversalsIllConditioned << " ill-conditioned (within 1e-6 of grazing, or a perturbation of 1024 ε leaves the path), "
          << reversalsNotSequential << " not sequential (a segment crosses another surface)\n";
        s << "critical-angle rays: " << criticalRays << " (" << criticalTir << " totally reflected)\n";
    }
    if (photons > 0) {
        s << "photons: " << photons << " traced, " << arrivals << " sensor arrivals\n";
        for (const auto& [fate, count] : fates) s << "  " << fate << ": " << count << "\n";
    }
    for (const auto& [what, count] : findings) s << "finding " << count << "x: " << what << "\n";
    if (renders > 0) s << "renders: " << renders << " (" << renderPhotons << " photons)\n";
    s << "failures: " << failures.size() << "\n";
    for (const std::string& f : failures) s << "  " << f << "\n";
    return s.str();
}

StressReport runSequentialStress(const StressConfig& config) {
    StressReport report;
    forEachLens("sequential", config, report, [&](Context& ctx, const LensSystem& lens, Rng& rng) {
        for (int i = 0; i < config.raysPerLens; ++i) {
            const double wavelengthNm = uniform(rng, 380.0, 780.0);
            const SpectralIndices indices = lens.indicesAt(wavelengthNm);
            const SequentialCase c = sequentialCase(i % 8, lens, indices, rng);
            TraceResult result;
            ReversalOutcome rev;
            const std::string problem = runCase(lens, indices, c, &result, &rev);
            ++report.rays;
            report.raysOk += result.ok();
            ++report.statuses[toString(result.status)];
            if (i % 8 == 6) {
                ++report.criticalRays;
                report.criticalTir += result.status == TraceStatus::TotalInternalReflection;
            }
            switch (rev.kind) {
                case ReversalOutcome::Compared:
                    ++report.reversalsCompared;
                    report.worstReversalRatio = std::max(report.worstReversalRatio, rev.ratio);
                    break;
                case ReversalOutcome::NotReturned: ++report.reversalsNotReturned; break;
                case ReversalOutcome::IllConditioned: ++report.reversalsIllConditioned; break;
                case ReversalOutcome::NotSequential: ++report.reversalsNotSequential; break;
                default: break;
            }
            if (!problem.empty()) ctx.fail(problem, sequentialReproducer(c, wavelengthNm));
        }
    });
    return report;
}

StressReport runPhotonStress(const StressConfig& config) {
    StressReport report;
    long lost = 0;
    forEachLens("photon", config, report, [&](Context& ctx, const LensSystem& lens, Rng& rng) {
        PhotonCase c;
        const double v = rng.uniform();
        if (v < 0.3) c.materials = {1.0, 1.0, 1.0};
        else if (v < 0.6) c.materials = {rng.uniform(), rng.uniform(), rng.uniform()};
        c.maxBounces = chance(rng, 0.7) ? -1 : uniformInt(rng, 0, 6);
        c.rngSeed = mixBits(config.seed) + static_cast<std::uint64_t>(ctx.lensIndex);
        const PhotonTracer tracer(lens, c.materials, c.maxBounces);
        bool coincident = false;  // two consecutive vertices at the same z (a zero axial gap)
        for (int k = 0; k + 1 < lens.surfaceCount(); ++k)
            coincident |= lens.surface(k + 1).vertexZMm == lens.surface(k).vertexZMm;
        PhotonHistory h;
        long fates[static_cast<int>(PhotonFate::Count)] = {};
        for (int i = 0; i < config.photonsPerLens; ++i) {
            c.ray = objectSpaceRay(static_cast<ObjectRay>(i % static_cast<int>(ObjectRay::Count)), lens, rng);
            c.wavelengthNm = uniform(rng, 380.0, 780.0);
            c.rngStream = static_cast<std::uint64_t>(i);
            Rng photonRng(c.rngSeed, c.rngStream);
            tracer.trace(lens.indicesAt(c.wavelengthNm), c.ray, photonRng, h);
            ++report.photons;
            report.arrivals += h.arrivalCount;
            const std::string problem = photonProblem(lens, c, h);
            if (!problem.empty()) {
                ctx.fail(problem, photonReproducer(c));
                continue;
            }
            ++fates[static_cast<int>(h.fate)];
            if (h.fate == PhotonFate::Lost || h.fate == PhotonFate::EventLimit) {
                const char* kinds[] = {"axial ray", "field ray", "grazing ray", "front-edge ray"};
                std::string what = h.fate == PhotonFate::Lost ? "photon lost (no boundary found)"
                                   : h.arrivalCount == kMaxSensorArrivals ? "photon stopped after the maximum sensor arrivals"
                                                                          : "photon stopped after the maximum event count";
                what += std::string(", ") + kinds[i % static_cast<int>(ObjectRay::Count)];
                if (coincident) what += ", lens with coincident vertices";
                ++report.findings[what];
                lost += h.fate == PhotonFate::Lost;
                ctx.fail(what, photonReproducer(c), false);
            }
        }
        // Energy: with analog sampling every photon ends in exactly one fate (the test checks that
        // the fates add up to the photons traced).
        for (int f = 0; f < static_cast<int>(PhotonFate::Count); ++f)
            if (fates[f] > 0) report.fates[toString(static_cast<PhotonFate>(f))] += fates[f];
    });
    if (report.photons > 0 && static_cast<double>(lost) > kMaxLostFraction * report.photons)
        report.failures.push_back(std::to_string(lost) + " photons lost out of " + std::to_string(report.photons) +
                                  " (more than the allowed fraction " + std::to_string(kMaxLostFraction) + ")");
    return report;
}

StressReport runRenderStress(const StressConfig& config) {
    StressReport report;
    if (config.renderEvery <= 0) return report;
    const std::filesystem::path dir =
        config.reproducerDir.empty() ? std::filesystem::temp_directory_path() / "flare_stress" : std::filesystem::path(config.reproducerDir);
    std::filesystem::create_directories(dir);
    int built = 0;
    forEachLens("render", config, report, [&](Context& ctx, const LensSystem& builtLens, Rng& rng) {
        if (built++ % config.renderEvery != 0) return;
        const std::string stem = "render-seed" + std::to_string(config.seed) + "-lens" + std::to_string(ctx.lensIndex);
        const std::string lensPath = (dir / (stem + ".lens")).string();
        std::ofstream(lensPath) << ctx.lens->text;

        // The scene: a tiny square-pixel film and one to three lights of every type.
        const int widthPx = 24;
        const double widthMm = builtLens.sensor().widthMm;
        const int heightPx = std::max(1, static_cast<int>(std::lround(widthPx * builtLens.sensor().heightMm / widthMm)));
        std::string lights;
        const int lightCount = uniformInt(rng, 1, std::max(1, config.maxLights));
        for (int l = 0; l < lightCount; ++l) {
            if (l > 0) lights += ",\n";
            const double v = rng.uniform();
            const char* spectra[] = {"\"d65\"", "\"equal_energy\"", "{ \"blackbody_k\": 3000 }"};
            const std::string spectrum = std::string(", \"spectrum\": ") + spectra[uniformInt(rng, 0, 2)];
            if (v < 0.6) {
                const double limit = chance(rng, 0.3) ? 89.9 : 30.0;
                const bool axial = chance(rng, 0.2);
                const double fx = axial ? 0.0 : uniform(rng, -limit, limit), fy = axial ? 0.0 : uniform(rng, -limit, limit);
                const double diameter = chance(rng, 0.5) ? 0.0 : uniform(rng, 0.0, 20.0);
                lights += "{ \"type\": \"directional\", \"field_deg\": [" + exact(fx) + ", " + exact(fy) +
                          "], \"angular_diameter_deg\": " + exact(diameter) + spectrum + " }";
            } else {
                const double z = -logUniform(rng, 0.0, 5.0);
                const double x = uniform(rng, -2.0, 2.0) * std::abs(z), y = uniform(rng, -2.0, 2.0) * std::abs(z);
                if (v < 0.8) {
                    lights += "{ \"type\": \"point\", \"position_mm\": [" + exact(x) + ", " + exact(y) + ", " + exact(z) + "]" +
                              spectrum + " }";
                } else {
                    // The whole disk must lie in front of the lens: keep its radius below |z| / 2.
                    lights += "{ \"type\": \"disk\", \"position_mm\": [" + exact(x) + ", " + exact(y) + ", " + exact(z) +
                              "], \"radius_mm\": " + exact(0.5 * std::abs(z) * rng.uniform() + 1e-3) + spectrum + " }";
                }
            }
        }
        const int order = builtLens.surfaceCount() <= 8 && chance(rng, 0.2) ? 4 : 2;
        const std::string sceneText = "{\n  \"lens\": \"" + lensPath + "\",\n  \"sensor\": { \"width_mm\": " + exact(widthMm) +
                                      ", \"height_mm\": " + exact(widthMm * heightPx / widthPx) + ", \"resolution\": [" +
                                      std::to_string(widthPx) + ", " + std::to_string(heightPx) + "] },\n  \"lights\": [\n" +
                                      lights + "\n  ],\n  \"render\": { \"ghost_order\": " + std::to_string(order) + " }\n}\n";
        const std::string scenePath = (dir / (stem + ".json")).string();
        std::ofstream(scenePath) << sceneText;
        const std::string where = " (scene " + scenePath + ")";
        try {
            const Scene scene = parseSceneText(sceneText, scenePath, "");
            const LensSystem lens = buildSceneLens(scene);
            RenderOptions options;
            options.mode = chance(rng, 0.5) ? RenderOptions::Mode::Naive : RenderOptions::Mode::Guided;
            options.seed = rng.next();
            options.maxBounces = chance(rng, 0.7) ? -1 : uniformInt(rng, 0, 6);
            options.perGhostLayers = chance(rng, 0.5);
            options.analysis.order = scene.render.ghostOrder;
            const double a = rng.uniform();
            options.materials = a < 0.4 ? InteriorMaterials{} : a < 0.7 ? InteriorMaterials{1.0, 1.0, 1.0}
                                                                        : InteriorMaterials{rng.uniform(), rng.uniform(), rng.uniform()};
            options.film.widthPx = widthPx;
            options.film.heightPx = heightPx;
            options.film.widthMm = lens.sensor().widthMm;
            options.film.heightMm = lens.sensor().heightMm;
            const int kernel = uniformInt(rng, 0, 2);
            options.film.kernel = static_cast<FilmSettings::Kernel>(kernel);
            options.film.radiusPx = kernel == 0 ? uniform(rng, 0.5, 3.0) : 4.0;
            options.batchPhotons = 256;
            options.batchesPerPass = 4;
            Renderer renderer(lens, scene.lights, options);
            for (int p = 0; p < config.renderPasses; ++p) renderer.runPass();
            ++report.renders;
            report.renderPhotons += renderer.statistics().photons;

            auto check = [&](bool ok, const std::string& what) {
                if (ok) return true;
                ctx.fail("render: " + what + where, "");
                return false;
            };
            for (int l = 0; l < static_cast<int>(renderer.layerNames().size()); ++l) {
                const std::vector<float> xyz = renderer.layerXyz(l);
                const bool fin = std::all_of(xyz.begin(), xyz.end(), [](float x) { return std::isfinite(x); });
                const bool nonNegative = std::all_of(xyz.begin(), xyz.end(), [](float x) { return x >= 0.0f; });
                check(fin, "non-finite pixel in layer " + renderer.layerNames()[l]);
                check(nonNegative, "negative pixel in layer " + renderer.layerNames()[l]);
            }
            const std::vector<float> variance = renderer.film().varianceRgb();
            check(std::all_of(variance.begin(), variance.end(), [](float x) { return std::isfinite(x); }), "non-finite variance");
            for (const auto* list : {&renderer.tallies(), &renderer.layerTallies()})
                for (const PathTally& t : *list) {
                    const double power = renderer.tallyPowerW(t), error = renderer.tallyStandardErrorW(t);
                    if (!check(std::isfinite(power) && std::isfinite(error) && power >= 0.0 && error >= 0.0,
                               (std::isfinite(power) && std::isfinite(error) ? "" : "non-finite ") +
                                   std::string("tally power ") + hex(power) + " ± " + hex(error)))
                        break;
                }
            for (const LightPlan& plan : renderer.lights())
                check(std::isfinite(plan.enteringPowerW) && plan.enteringPowerW >= 0.0, "entering power of " + plan.name);
            // Energy: every unguided photon ends in one fate, and the fates' powers add up to the
            // emitted power (the same weights summed in another grouping: relative 1e-12).
            const RenderStatistics& s = renderer.statistics();
            std::int64_t fatePhotons = 0;
            double fatePower = 0.0;
            for (int f = 0; f < static_cast<int>(PhotonFate::Count); ++f) {
                fatePhotons += s.fates[f].photons;
                fatePower += s.fates[f].powerW;
                if (s.fates[f].photons > 0) report.fates[toString(static_cast<PhotonFate>(f))] += s.fates[f].photons;
            }
            check(fatePhotons == s.unguidedPhotons, "fates count " + std::to_string(fatePhotons) + " photons, " +
                                                        std::to_string(s.unguidedPhotons) + " unguided were traced");
            check(std::isfinite(s.unguidedEmittedPowerW) && std::abs(fatePower - s.unguidedEmittedPowerW) <=
                                                               1e-12 * std::max(1.0, s.unguidedEmittedPowerW) * 16,
                  "fate powers " + hex(fatePower) + " differ from the emitted " + hex(s.unguidedEmittedPowerW));
            check(s.unguidedEnteredPowerW <= s.unguidedEmittedPowerW * (1.0 + 1e-12), "more power entered than emitted");
            check(s.guidedPhotons + s.unguidedPhotons <= s.photons, "photon counts");
        } catch (const InputError& e) {
            // A scene the reader or the lens refuses (counted, not a failure of the engine).
            ++report.rejections["render skipped: " + canonical(e.problem())];
        } catch (const std::exception& e) {
            ctx.fail(std::string("render threw: ") + e.what() + where, "");
        }
        std::filesystem::remove(lensPath);
        if (report.failures.empty()) std::filesystem::remove(scenePath);
    });
    // A clean run leaves nothing behind: the folder goes too when it is empty.
    std::error_code ec;
    std::filesystem::remove(dir, ec);
    return report;
}

std::string replay(const std::string& path) {
    std::ifstream in(path);
    if (!in) return "cannot open " + path;
    std::stringstream buffer;
    buffer << in.rdbuf();
    const std::string text = buffer.str();
    std::map<std::string, std::vector<std::string>> fields;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("#! ", 0) != 0) continue;
        std::istringstream words(line.substr(3));
        std::string key, word;
        words >> key;
        while (words >> word) fields[key].push_back(word);
    }
    auto number = [&](const std::string& key, size_t i) { return std::strtod(fields.at(key).at(i).c_str(), nullptr); };
    const LensSystem lens = LensSystem::build(parseLensText(text, path));
    const double wavelengthNm = number("wavelength_nm", 0);
    const Ray ray{{number("ray", 0), number("ray", 1), number("ray", 2)}, {number("ray", 3), number("ray", 4), number("ray", 5)}};
    const std::string check = fields.at("check").at(0);
    if (check == "sequential") {
        SequentialCase c;
        c.ray = ray;
        const auto& p = fields.at("path");
        c.start = std::stoi(p.at(0));
        c.direction = std::stoi(p.at(1));
        c.end = p.at(2) == "sensor" ? SequentialPath::End::Sensor : SequentialPath::End::ObjectSpace;
        for (size_t i = 3; i < p.size(); ++i) c.reflections.push_back(std::stoi(p[i]));
        c.clip = fields.at("clip").at(0) == "1";
        const std::string expect = fields.at("expect").at(0);
        for (Expect e : {Expect::Finite, Expect::Tir, Expect::Refract, Expect::OnAxis, Expect::Reversible})
            if (expect == toString(e)) c.expect = e;
        c.surface = std::stoi(fields.at("expect").at(1));
        TraceResult result;
        ReversalOutcome rev;
        const std::string problem = runCase(lens, lens.indicesAt(wavelengthNm), c, &result, &rev);
        return problem.empty() ? "" : problem + " (status " + toString(result.status) + " at surface " +
                                          std::to_string(result.surface) + ")";
    }
    PhotonCase c;
    c.ray = ray;
    c.wavelengthNm = wavelengthNm;
    const auto& p = fields.at("photon");
    c.rngSeed = std::stoull(p.at(0));
    c.rngStream = std::stoull(p.at(1));
    c.materials = {std::strtod(p.at(2).c_str(), nullptr), std::strtod(p.at(3).c_str(), nullptr), std::strtod(p.at(4).c_str(), nullptr)};
    c.maxBounces = std::stoi(p.at(5));
    PhotonHistory h;
    tracePhoton(lens, c, h);
    std::string problem = photonProblem(lens, c, h);
    if (problem.empty() && (h.fate == PhotonFate::Lost || h.fate == PhotonFate::EventLimit))
        problem = std::string("photon fate ") + toString(h.fate) + " after " + std::to_string(h.events) + " events, " +
                  std::to_string(h.reflections) + " reflections, " + std::to_string(h.arrivalCount) + " arrivals";
    return problem;
}

}  // namespace flare::stress
