#include "flare/photons/LightSampler.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

namespace flare {

namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;
constexpr double kMm2PerM2 = 1e6;

// Axial depth of the first surface over its clear aperture: how far behind the pupil plane an
// entering ray may still be on its way to the glass.
double frontDepthMm(const LensSystem& lens) {
    const Surface& first = lens.surface(0);
    double depth = 0.0;
    for (int k = 0; k <= 32; ++k) {
        const double r = first.semiApertureMm * k / 32.0;
        double sag = 0.0;
        if (first.sagMm(r * r, &sag)) depth = std::max(depth, std::abs(sag));
    }
    return depth + 1.0;
}

}  // namespace

LightSampler::LightSampler(const LightSpec& light, const LensSystem& lens)
    : light_(light),
      // (A point the lens cannot see from in front, which a scene never holds, keeps parallel
      // rays along its direction: the render then finds it behind the lens and skips it.)
      grid_(light.type != LightSpec::Type::Directional && PupilGrid::inFront(lens, light.positionMm)
                ? PupilGrid::forPoint(lens, light.positionMm)
                : PupilGrid::forDirection(lens, light.travelDirection())) {
    const double depth = frontDepthMm(lens);
    // Widest angle between an emitted ray and the central direction.
    double spreadRad = 0.0;
    if (light.isRegion()) {
        double total = 0.0;
        for (const RegionPoint& p : light.region) {
            regionDirections_.push_back(directionFromFieldDeg(p.fieldXDeg, p.fieldYDeg));
            regionCdf_.push_back(total += std::max(p.share, 0.0));
            regionColour_.push_back(std::clamp(p.colour, 0, std::max(0, static_cast<int>(light.regionColours.size()) - 1)));
        }
        for (double& c : regionCdf_) c /= total;
        regionCdf_.back() = 1.0;
        ownSpectrum_ = toSpectrum(light.spectrum);
        const double ownY = spectrumXyz(ownSpectrum_).y;
        for (const glm::dvec3& rgb : light.regionColours) {
            SpectrumSpec colour;
            colour.kind = SpectrumSpec::Kind::Rgb;
            colour.rgb = rgb;
            colourSpectra_.push_back(toSpectrum(colour));
            colourScale_.push_back(ownY / spectrumXyz(colourSpectra_.back()).y);
        }
        spreadRad = light.apparentRadiusRad();
        // Every point's rays must cross the plane within the grid that the analysis, the masks and
        // the beams share: its window widens by what the inclination shifts the front aperture's
        // projection (the surface's depth times the tangent), and the rays start farther back.
        grid_.halfSizeMm += depth * std::tan(spreadRad);
        grid_.backOffMm += grid_.halfSizeMm * std::tan(spreadRad) + depth;
    } else if (light.type == LightSpec::Type::Directional) {
        const double halfAngle = 0.5 * light.angularDiameterDeg * kDegToRad;
        cosHalfAngle_ = std::cos(halfAngle);
        meanCosine_ = 0.5 * (1.0 + cosHalfAngle_);
        spreadRad = halfAngle;
    } else {
        const double distanceMm = glm::length(light.positionMm);
        spreadRad = std::atan((grid_.halfSizeMm + light.radiusMm) / std::max(distanceMm - depth, 1e-3));
        const glm::dvec3 n = light.diskNormal();
        const glm::dvec3 helper = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
        diskU_ = glm::normalize(glm::cross(helper, n));
        diskV_ = glm::cross(n, diskU_);
    }
    // A ray inclined by `spread` to the central direction crosses the plane up to depth·tan(spread)
    // away from where it meets the glass.
    emissionHalfSizeMm_ = 1.02 * grid_.halfSizeMm + depth * std::tan(std::min(spreadRad, 1.4));
}

int LightSampler::regionPoint(double u1) const {
    const auto it = std::upper_bound(regionCdf_.begin(), regionCdf_.end(), u1);
    return static_cast<int>(std::min<std::ptrdiff_t>(it - regionCdf_.begin(), static_cast<std::ptrdiff_t>(regionCdf_.size()) - 1));
}

double LightSampler::colourFactor(double u1, double wavelengthNm) const {
    if (colourSpectra_.empty()) return 1.0;
    const double own = ownSpectrum_.value(wavelengthNm);
    if (!(own > 0.0)) return 0.0;
    const int c = regionColour_[static_cast<size_t>(regionPoint(u1))];
    return colourSpectra_[static_cast<size_t>(c)].value(wavelengthNm) * colourScale_[static_cast<size_t>(c)] / own;
}

std::vector<PupilGrid> LightSampler::rimGrids(int count) const {
    std::vector<PupilGrid> rims;
    if (!hasExtent()) return rims;
    if (!light_.isRegion()) {
        for (int k = 0; k < count; ++k) rims.push_back(gridFor(1.0, (k + 0.5) / count));
        return rims;
    }
    // The point farthest along each of the azimuths on the plane (e1, e2).
    const int azimuths = std::max(count, 8);
    std::vector<int> chosen;
    for (int k = 0; k < azimuths; ++k) {
        const double phi = 2.0 * std::numbers::pi * k / azimuths;
        const glm::dvec3 towards = std::cos(phi) * grid_.e1 + std::sin(phi) * grid_.e2;
        int best = 0;
        double farthest = -1e300;
        for (size_t i = 0; i < regionDirections_.size(); ++i) {
            const double along = glm::dot(regionDirections_[i], towards);
            if (along > farthest) farthest = along, best = static_cast<int>(i);
        }
        if (std::find(chosen.begin(), chosen.end(), best) == chosen.end()) chosen.push_back(best);
    }
    for (int i : chosen) {
        PupilGrid grid = grid_;
        grid.direction = regionDirections_[static_cast<size_t>(i)];
        rims.push_back(grid);
    }
    return rims;
}

PupilGrid LightSampler::gridFor(double u1, double u2) const {
    if (light_.type == LightSpec::Type::Point) return grid_;
    if (light_.type == LightSpec::Type::Disk) return grid_.withSource(diskPoint(u1, u2));
    PupilGrid grid = grid_;
    grid.direction = rayThrough(0.0, 0.0, u1, u2).ray.direction;
    return grid;
}

glm::dvec3 LightSampler::diskPoint(double u1, double u2) const {
    if (!(light_.radiusMm > 0.0)) return light_.positionMm;
    const double r = light_.radiusMm * std::sqrt(u1);
    const double phi = 2.0 * std::numbers::pi * u2;
    return light_.positionMm + r * (std::cos(phi) * diskU_ + std::sin(phi) * diskV_);
}

EmittedRay LightSampler::rayThrough(double aMm, double bMm, double u1, double u2) const {
    const glm::dvec3 onPlane = grid_.centreMm + aMm * grid_.e1 + bMm * grid_.e2;
    EmittedRay out;
    if (!regionDirections_.empty()) {
        // A point drawn by its share: the light's whole irradiance (normal to the point's rays, E_i
        // = share·E, drawn with probability share) on the plane normal to the centre, cosθ of it.
        const glm::dvec3& direction = regionDirections_[static_cast<size_t>(regionPoint(u1))];
        out.ray = {onPlane - grid_.backOffMm * direction, direction};
        out.powerPerMm2 = light_.power / kMm2PerM2 * glm::dot(direction, grid_.direction);
        return out;
    }
    if (light_.type == LightSpec::Type::Directional) {
        // Uniform over the cone's solid angle. Radiance L is uniform over the disk and the light's
        // irradiance E on the plane is ∫ L cosθ dω = L Ω ⟨cosθ⟩, so a ray drawn with density 1/Ω
        // carries E cosθ / ⟨cosθ⟩ per unit area.
        const double cosTheta = 1.0 - u1 * (1.0 - cosHalfAngle_);
        const double sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
        const double phi = 2.0 * std::numbers::pi * u2;
        const glm::dvec3 direction = cosTheta * grid_.direction +
                                     sinTheta * (std::cos(phi) * grid_.e1 + std::sin(phi) * grid_.e2);
        out.ray = {onPlane - grid_.backOffMm * direction, direction};
        out.powerPerMm2 = light_.power / kMm2PerM2 * cosTheta / meanCosine_;
        return out;
    }
    // Point or disk: a ray from the (sampled) emitting point through the plane point. The solid
    // angle of a plane element dA seen from the source is dA cosθ' / r²; a Lambertian disk of
    // on-axis intensity I sends I cosθs dω from a point drawn uniformly over its area.
    const glm::dvec3 source = light_.type == LightSpec::Type::Disk ? diskPoint(u1, u2) : light_.positionMm;
    double cosSource = 1.0;
    const glm::dvec3 toPlane = onPlane - source;
    const double distance2 = glm::dot(toPlane, toPlane);
    out.ray = grid_.rayFrom(source, aMm, bMm);
    out.sourceMm = source;
    const glm::dvec3& direction = out.ray.direction;
    if (light_.type == LightSpec::Type::Disk) cosSource = glm::dot(direction, light_.diskNormal());
    const double cosPlane = glm::dot(direction, grid_.direction);
    out.powerPerMm2 = cosSource > 0.0 && cosPlane > 0.0 ? light_.power * cosSource * cosPlane / distance2 : 0.0;
    return out;
}

}  // namespace flare
