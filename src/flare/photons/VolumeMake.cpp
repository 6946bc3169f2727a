#include "flare/photons/VolumeMake.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "flare/core/Random.h"

namespace flare {

namespace {

constexpr double kPi = std::numbers::pi;
// Largest voxel count of the cylinder's bounding box makeVolume accepts (memory and time guard).
constexpr double kMaxVoxels = static_cast<double>(1u << 28);
// Striae values below this fraction of the density are left inactive (sparsity).
constexpr double kStriaCutoff = 1e-3;

std::string formatNumber(double x) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%g", x);
    return buffer;
}

// The voxel lattice of the cylinder: voxel (i, j, k) spans [i v, (i + 1) v] × [j v, (j + 1) v] ×
// [k v, (k + 1) v], columns i, j in [−n, n), layers k in [0, layers).
struct Lattice {
    double v = 0.0, radius = 0.0;
    int n = 0, layers = 0;

    // Whether the whole column (i, j) lies inside the cylinder (its farthest corner from the axis).
    bool columnInside(int i, int j) const {
        const double x = std::max(std::abs(i * v), std::abs((i + 1) * v));
        const double y = std::max(std::abs(j * v), std::abs((j + 1) * v));
        return x * x + y * y <= radius * radius * (1.0 + 1e-12);
    }
    glm::dvec3 centre(int i, int j, int k) const { return {(i + 0.5) * v, (j + 0.5) * v, (k + 0.5) * v}; }
    double topMm() const { return layers * v; }
};

// ---- Value noise ----------------------------------------------------------------------------------
// Lattice values in [−1, 1] from a hash of the integer point and the seed, interpolated with the
// quintic fade 6t⁵ − 15t⁴ + 10t³ (C² continuous); a convex combination, so the result stays in [−1, 1].
double latticeValue(std::int64_t x, std::int64_t y, std::int64_t z, std::uint64_t seed) {
    std::uint64_t h = mixBits(seed ^ 0x243f6a8885a308d3ull);
    h = mixBits(h ^ static_cast<std::uint64_t>(x));
    h = mixBits(h ^ static_cast<std::uint64_t>(y));
    h = mixBits(h ^ static_cast<std::uint64_t>(z));
    return static_cast<double>(h >> 11) * 0x1.0p-52 - 1.0;
}

double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

double valueNoise(const glm::dvec3& p, std::uint64_t seed) {
    const glm::dvec3 cell = glm::floor(p);
    const glm::dvec3 f = p - cell;
    const auto x0 = static_cast<std::int64_t>(cell.x), y0 = static_cast<std::int64_t>(cell.y),
               z0 = static_cast<std::int64_t>(cell.z);
    const double u = fade(f.x), w = fade(f.y), s = fade(f.z);
    double result = 0.0;
    for (int c = 0; c < 8; ++c) {
        const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
        const double weight = (dx ? u : 1.0 - u) * (dy ? w : 1.0 - w) * (dz ? s : 1.0 - s);
        result += weight * latticeValue(x0 + dx, y0 + dy, z0 + dz, seed);
    }
    return result;
}

// Fractal sum of up to four octaves (frequency ×2, amplitude ×½), normalised to [−1, 1].
double fractalNoise(const glm::dvec3& p, std::uint64_t seed, int octaves) {
    double sum = 0.0, amplitude = 1.0, norm = 0.0, frequency = 1.0;
    for (int octave = 0; octave < octaves; ++octave) {
        sum += amplitude * valueNoise(p * frequency + glm::dvec3(17.3 * octave), seed + octave);
        norm += amplitude;
        amplitude *= 0.5;
        frequency *= 2.0;
    }
    return sum / norm;
}

// ---- Kinds ----------------------------------------------------------------------------------------

void makeHaze(const VolumeMakeOptions& o, const Lattice& lattice, VolumeGrid::Builder& builder) {
    const double correlation = o.correlationMm > 0.0 ? o.correlationMm : o.radiusMm / 4.0;
    // Octaves whose lattice is at least two voxels apart (no aliasing), at least one, at most four.
    int octaves = 1;
    while (octaves < 4 && correlation / std::ldexp(1.0, octaves) >= 2.0 * lattice.v) ++octaves;
    // Two passes in the same order: the noise first (for its range), then the values.
    std::vector<double> noise;
    double lo = 1.0, hi = -1.0;
    for (int i = -lattice.n; i < lattice.n; ++i)
        for (int j = -lattice.n; j < lattice.n; ++j) {
            if (!lattice.columnInside(i, j)) continue;
            for (int k = 0; k < lattice.layers; ++k) {
                const double value = fractalNoise(lattice.centre(i, j, k) / correlation, o.seed, octaves);
                lo = std::min(lo, value);
                hi = std::max(hi, value);
                noise.push_back(value);
            }
        }
    // Stretched so that the extremes are exactly (1 − variation)·density and density.
    const double span = hi - lo;
    size_t next = 0;
    for (int i = -lattice.n; i < lattice.n; ++i)
        for (int j = -lattice.n; j < lattice.n; ++j) {
            if (!lattice.columnInside(i, j)) continue;
            for (int k = 0; k < lattice.layers; ++k) {
                const double value = noise[next++];
                const double u = span > 0.0 ? (value - lo) / span : 1.0;
                builder.set(i, j, k, o.density * (1.0 - o.variation * (1.0 - u)));
            }
        }
}

void makeStriae(const VolumeMakeOptions& o, const Lattice& lattice, VolumeGrid::Builder& builder, Rng& rng) {
    struct Sheet {
        glm::dvec2 normal, tangent;
        double offset, centre, halfLength, ramp;
        double lateralAmplitude, lateralWavelength, lateralPhase;
        double axialAmplitude, axialWavelength, axialPhase;
        double peak;
    };
    const double R = o.radiusMm, T = lattice.topMm();
    const double orientation = 2.0 * kPi * rng.uniform();
    std::vector<Sheet> sheets;
    for (int s = 0; s < o.count; ++s) {
        Sheet sheet{};
        const double angle = orientation + (rng.uniform() - 0.5) * kPi / 6.0;  // within ±15° of each other
        sheet.normal = {std::cos(angle), std::sin(angle)};
        sheet.tangent = {-sheet.normal.y, sheet.normal.x};
        sheet.offset = (2.0 * rng.uniform() - 1.0) * 0.9 * R;
        sheet.centre = (2.0 * rng.uniform() - 1.0) * 0.5 * R;
        sheet.halfLength = (0.3 + 0.7 * rng.uniform()) * R;
        sheet.ramp = 0.3 * sheet.halfLength;
        sheet.lateralAmplitude = (0.02 + 0.04 * rng.uniform()) * R;
        sheet.lateralWavelength = (0.3 + 0.5 * rng.uniform()) * R;
        sheet.lateralPhase = 2.0 * kPi * rng.uniform();
        sheet.axialAmplitude = 0.15 * T * rng.uniform();
        sheet.axialWavelength = (1.0 + 2.0 * rng.uniform()) * T;
        sheet.axialPhase = 2.0 * kPi * rng.uniform();
        sheet.peak = (0.5 + 0.5 * rng.uniform()) * o.density;
        sheets.push_back(sheet);
    }
    // Gaussian cross-section of FWHM featureMm, widened by the voxel's box filter (variance v²/12)
    // with its peak lowered to keep the sheet's integral: coarse voxels neither miss nor thicken it.
    const double sigma = o.featureMm / (2.0 * std::sqrt(2.0 * std::log(2.0)));
    const double sigmaEff = std::sqrt(sigma * sigma + lattice.v * lattice.v / 12.0);
    const double scale = sigma / sigmaEff, reach = 3.0 * sigmaEff;

    std::vector<double> column(static_cast<size_t>(lattice.layers));
    for (int i = -lattice.n; i < lattice.n; ++i)
        for (int j = -lattice.n; j < lattice.n; ++j) {
            if (!lattice.columnInside(i, j)) continue;
            std::fill(column.begin(), column.end(), 0.0);
            const glm::dvec3 c = lattice.centre(i, j, 0);
            const glm::dvec2 p{c.x, c.y};
            bool any = false;
            for (const Sheet& sheet : sheets) {
                const double along = glm::dot(sheet.tangent, p);
                const double window = glm::clamp((sheet.halfLength - std::abs(along - sheet.centre)) / sheet.ramp, 0.0, 1.0);
                if (window <= 0.0) continue;
                const double g = glm::dot(sheet.normal, p) - sheet.offset -
                                 sheet.lateralAmplitude * std::sin(2.0 * kPi * along / sheet.lateralWavelength + sheet.lateralPhase);
                if (std::abs(g) > sheet.axialAmplitude + reach) continue;
                const double amplitude = sheet.peak * scale * window * window * (3.0 - 2.0 * window);  // smoothstep
                for (int k = 0; k < lattice.layers; ++k) {
                    const double z = (k + 0.5) * lattice.v;
                    const double f = g - sheet.axialAmplitude * std::sin(2.0 * kPi * z / sheet.axialWavelength + sheet.axialPhase);
                    if (std::abs(f) > reach) continue;
                    column[k] = std::max(column[k], amplitude * std::exp(-0.5 * f * f / (sigmaEff * sigmaEff)));
                    any = true;
                }
            }
            if (!any) continue;
            for (int k = 0; k < lattice.layers; ++k)
                if (column[k] >= kStriaCutoff * o.density) builder.set(i, j, k, column[k]);
        }
}

// An ellipsoid: centre, orthonormal axes (columns of `axes`) and semi-axes.
struct Ellipsoid {
    glm::dvec3 centre;
    glm::dmat3 axes{1.0};
    glm::dvec3 semiAxes;
};

// Adds density × (the fraction of each voxel inside e) to the voxels it meets, clamped to density;
// voxels outside the cylinder are left alone. The fraction is 1 or 0 for voxels wholly inside or
// outside (tested in the ellipsoid's unit-sphere space) and estimated on an m³ sub-lattice for the
// voxels its surface crosses; those estimates are then scaled so that the fractions add up to the
// ellipsoid's exact volume (4/3 π abc) in voxels: a feature's total is the same for every voxel size,
// and one much smaller than a voxel, missed by the sub-lattice, still lands in its centre's voxel.
void addEllipsoid(const Ellipsoid& e, double density, const Lattice& lattice, VolumeGrid::Builder& builder) {
    const double v = lattice.v;
    const double aMin = std::min({e.semiAxes.x, e.semiAxes.y, e.semiAxes.z});
    const double aMax = std::max({e.semiAxes.x, e.semiAxes.y, e.semiAxes.z});
    const double halfDiagonal = 0.5 * std::sqrt(3.0) * v / aMin;  // a voxel's reach in unit space
    const int m = std::clamp(static_cast<int>(std::ceil(4.0 * v / aMin)), 4, 16);
    const auto toUnit = [&](const glm::dvec3& p) { return (glm::transpose(e.axes) * (p - e.centre)) / e.semiAxes; };
    const auto inCylinder = [&](int i, int j, int k) {
        return i >= -lattice.n && i < lattice.n && j >= -lattice.n && j < lattice.n && k >= 0 && k < lattice.layers &&
               lattice.columnInside(i, j);
    };

    struct Part {
        glm::ivec3 voxel;
        double fraction;
        bool boundary;
    };
    std::vector<Part> parts;
    double inside = 0.0, boundary = 0.0;
    const auto lo = glm::ivec3(glm::floor((e.centre - aMax) / v)), hi = glm::ivec3(glm::floor((e.centre + aMax) / v));
    for (int i = lo.x; i <= hi.x; ++i)
        for (int j = lo.y; j <= hi.y; ++j)
            for (int k = lo.z; k <= hi.z; ++k) {
                const glm::dvec3 centre = lattice.centre(i, j, k);
                const double r = glm::length(toUnit(centre));
                if (r + halfDiagonal <= 1.0) {
                    parts.push_back({{i, j, k}, 1.0, false});
                    inside += 1.0;
                    continue;
                }
                if (r - halfDiagonal >= 1.0) continue;
                int hits = 0;
                for (int a = 0; a < m; ++a)
                    for (int b = 0; b < m; ++b)
                        for (int c = 0; c < m; ++c) {
                            const glm::dvec3 p = centre + v * (glm::dvec3(a + 0.5, b + 0.5, c + 0.5) / double(m) - 0.5);
                            const glm::dvec3 q = toUnit(p);
                            hits += glm::dot(q, q) <= 1.0;
                        }
                if (hits == 0) continue;
                const double fraction = static_cast<double>(hits) / (m * m * m);
                parts.push_back({{i, j, k}, fraction, true});
                boundary += fraction;
            }

    const double exact = 4.0 / 3.0 * kPi * e.semiAxes.x * e.semiAxes.y * e.semiAxes.z / (v * v * v);
    if (parts.empty()) {
        const glm::ivec3 c(glm::floor(e.centre / v));
        parts.push_back({c, std::min(1.0, exact), false});
    } else if (boundary > 0.0) {
        const double scale = std::max(0.0, exact - inside) / boundary;
        for (Part& p : parts)
            if (p.boundary) p.fraction = std::min(1.0, p.fraction * scale);
    }
    for (const Part& p : parts) {
        if (!inCylinder(p.voxel.x, p.voxel.y, p.voxel.z)) continue;
        const double value = std::min(density, builder.get(p.voxel.x, p.voxel.y, p.voxel.z) + density * p.fraction);
        builder.set(p.voxel.x, p.voxel.y, p.voxel.z, value);
    }
}

// A centre uniform over the part of the cylinder where a feature of radius `reach` (plus a voxel
// of margin) lies wholly inside; on the axis / mid-thickness when there is no such part.
glm::dvec3 featureCentre(double reach, const Lattice& lattice, Rng& rng) {
    const double v = lattice.v;
    const double rho = std::max(0.0, lattice.radius - reach - v * std::sqrt(2.0)) * std::sqrt(rng.uniform());
    const double phi = 2.0 * kPi * rng.uniform();
    const double zLo = reach + v, zHi = lattice.topMm() - reach - v;
    const double u = rng.uniform();
    const double z = zLo <= zHi ? zLo + (zHi - zLo) * u : 0.5 * lattice.topMm();
    return {rho * std::cos(phi), rho * std::sin(phi), z};
}

void makeBubbles(const VolumeMakeOptions& o, const Lattice& lattice, VolumeGrid::Builder& builder, Rng& rng) {
    for (int b = 0; b < o.count; ++b) {
        const double radius = o.featureMm * (0.5 + rng.uniform());
        Ellipsoid e;
        e.centre = featureCentre(radius, lattice, rng);
        e.semiAxes = glm::dvec3(radius);
        addEllipsoid(e, o.density, lattice, builder);
    }
}

// A uniformly distributed rotation (Shoemake's method: a uniform unit quaternion).
glm::dmat3 randomRotation(Rng& rng) {
    const double u1 = rng.uniform(), u2 = 2.0 * kPi * rng.uniform(), u3 = 2.0 * kPi * rng.uniform();
    const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
    const double x = a * std::sin(u2), y = a * std::cos(u2), z = b * std::sin(u3), w = b * std::cos(u3);
    return glm::dmat3(1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y),  // first column
                      2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x),  // second
                      2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)); // third
}

void makeInclusions(const VolumeMakeOptions& o, const Lattice& lattice, VolumeGrid::Builder& builder, Rng& rng) {
    for (int s = 0; s < o.count; ++s) {
        Ellipsoid e;
        for (int c = 0; c < 3; ++c) e.semiAxes[c] = 0.5 * o.featureMm * (0.5 + 0.5 * rng.uniform());
        e.axes = randomRotation(rng);
        e.centre = featureCentre(std::max({e.semiAxes.x, e.semiAxes.y, e.semiAxes.z}), lattice, rng);
        addEllipsoid(e, o.density, lattice, builder);
    }
}

void require(bool condition, const std::string& problem) {
    if (!condition) throw std::invalid_argument(problem);
}

}  // namespace

const char* toString(VolumeMakeOptions::Kind kind) {
    switch (kind) {
        case VolumeMakeOptions::Kind::Haze: return "haze";
        case VolumeMakeOptions::Kind::Striae: return "striae";
        case VolumeMakeOptions::Kind::Bubbles: return "bubbles";
        case VolumeMakeOptions::Kind::Inclusions: return "inclusions";
    }
    return "?";
}

std::optional<VolumeMakeOptions::Kind> parseVolumeKind(const std::string& name) {
    for (auto kind : {VolumeMakeOptions::Kind::Haze, VolumeMakeOptions::Kind::Striae, VolumeMakeOptions::Kind::Bubbles,
                      VolumeMakeOptions::Kind::Inclusions})
        if (name == toString(kind)) return kind;
    return std::nullopt;
}

std::string describe(const VolumeMakeOptions& o) {
    std::string s = std::string("flare volume make --kind ") + toString(o.kind) + " --radius " + formatNumber(o.radiusMm) +
                    " --thickness " + formatNumber(o.thicknessMm) + " --voxel " + formatNumber(o.voxelMm) +
                    " --seed " + std::to_string(o.seed) + " --density " + formatNumber(o.density);
    if (o.kind == VolumeMakeOptions::Kind::Haze) {
        s += " --correlation " + formatNumber(o.correlationMm > 0.0 ? o.correlationMm : o.radiusMm / 4.0) +
             " --variation " + formatNumber(o.variation);
    } else {
        s += " --count " + std::to_string(o.count) + " --feature " + formatNumber(o.featureMm);
    }
    if (o.gridName != "density") s += " --name " + o.gridName;
    return s;
}

VolumeGrid makeVolume(const VolumeMakeOptions& o) {
    const auto positive = [](double x) { return std::isfinite(x) && x > 0.0; };
    require(positive(o.radiusMm), "the radius must be > 0");
    require(positive(o.thicknessMm), "the thickness must be > 0");
    require(positive(o.voxelMm), "the voxel size must be > 0");
    require(positive(o.density), "the density must be > 0");
    require(positive(o.featureMm), "the feature size must be > 0");
    require(std::isfinite(o.correlationMm) && o.correlationMm >= 0.0, "the correlation length must be >= 0");
    require(o.variation >= 0.0 && o.variation <= 1.0, "the variation must lie in [0, 1]");
    require(o.kind == VolumeMakeOptions::Kind::Haze || o.count >= 1, "the count must be >= 1");
    require(!o.gridName.empty(), "the grid name must not be empty");

    Lattice lattice;
    lattice.v = o.voxelMm;
    lattice.radius = o.radiusMm;
    const double n = std::ceil(o.radiusMm / o.voxelMm - 1e-9);
    const double layers = std::floor(o.thicknessMm / o.voxelMm + 1e-9);
    require(layers >= 1.0, "the voxel (" + formatNumber(o.voxelMm) + " mm) is thicker than the element (" +
                               formatNumber(o.thicknessMm) + " mm)");
    require(o.voxelMm * std::sqrt(2.0) <= o.radiusMm * (1.0 + 1e-12),
            "the voxel (" + formatNumber(o.voxelMm) + " mm) is too large for the radius " + formatNumber(o.radiusMm) + " mm");
    require(4.0 * n * n * layers <= kMaxVoxels, "too many voxels (" + formatNumber(4.0 * n * n * layers) +
                                                    " in the bounding box, at most 2^28): use a coarser --voxel");
    lattice.n = static_cast<int>(n);
    lattice.layers = static_cast<int>(layers);

    VolumeGrid::Builder builder(o.gridName, o.voxelMm, glm::dvec3(0.0));
    Rng rng(o.seed, 0x766f6c756d65ull + static_cast<std::uint64_t>(o.kind));  // "volume" + kind
    switch (o.kind) {
        case VolumeMakeOptions::Kind::Haze: makeHaze(o, lattice, builder); break;
        case VolumeMakeOptions::Kind::Striae: makeStriae(o, lattice, builder, rng); break;
        case VolumeMakeOptions::Kind::Bubbles: makeBubbles(o, lattice, builder, rng); break;
        case VolumeMakeOptions::Kind::Inclusions: makeInclusions(o, lattice, builder, rng); break;
    }
    try {
        return builder.build(describe(o));
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string(e.what()) + ": the features may be too small for the voxel size or " +
                                    "too few; try a finer --voxel or a larger --feature / --count");
    }
}

}  // namespace flare
