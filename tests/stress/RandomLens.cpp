#include "RandomLens.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <optional>
#include <vector>

#include "flare/optics/Surface.h"

namespace flare::stress {

std::string exact(double value) {
    char buffer[40];
    std::snprintf(buffer, sizeof buffer, "%.17g", value);
    return buffer;
}

namespace {

constexpr const char* kCatalogGlasses[] = {"N-BK7", "N-FK5", "N-SF66", "S-LAH66", "N-LASF9", "S-FPL53",
                                           "F2",    "N-SF57", "TAF1",   "E-FDS1",  "N-KZFS4", "S-TIH53"};

struct Row {
    bool stop = false;
    Surface surface;            // radius, conic, asphere, semi-aperture (the stop: a plane)
    bool glassAfter = false;
    std::string material = "air";
    std::string coating;        // "" = the default coating
    bool planeAsZero = false;   // write a plane as "0" instead of "inf"
};

// The engine's profile of a surface for the edge-thickness check: the sag out to the clear
// aperture, flat beyond it (LensSystem.cpp, profileZMm).
double profileMm(const Surface& s, double r) {
    const double rc = std::min(r, s.semiApertureMm);
    double sag = 0.0;
    if (!s.sagMm(rc * rc, &sag)) sag = 0.0;
    return sag;
}

// Smallest vertex distance from a to b at which b's profile is nowhere in front of a's, sampled
// at 512 radii out to the radius the builder checks (the larger clear radius: beyond it both
// profiles are flat, also next to the stop, whose blades reach the barrel). The samples are a
// superset of the builder's 64, so the builder agrees wherever the profiles are smooth on that scale.
double requiredGapMm(const Row& a, const Row& b) {
    const double rMax = std::max(a.surface.semiApertureMm, b.surface.semiApertureMm);
    constexpr int kSamples = 512;
    double gap = 0.0;
    for (int k = 0; k <= kSamples; ++k) {
        const double r = rMax * k / kSamples;
        gap = std::max(gap, profileMm(a.surface, r) - profileMm(b.surface, r));
    }
    return gap;
}

std::string randomGlass(Rng& rng) {
    const double u = rng.uniform();
    if (u < 0.45) {
        const double v = rng.uniform();
        const double nd = v < 0.05 ? 1.4 : v < 0.10 ? 2.0 : uniform(rng, 1.4, 2.0);
        return exact(nd) + "/" + exact(uniform(rng, 18.0, 95.0));
    }
    if (u < 0.75) {
        const double v = rng.uniform();
        return "n=" + exact(v < 0.05 ? 1.4 : v < 0.10 ? 2.0 : uniform(rng, 1.4, 2.0));
    }
    return kCatalogGlasses[uniformInt(rng, 0, static_cast<int>(std::size(kCatalogGlasses)) - 1)];
}

// A refracting surface of clear radius saMm (which may shrink to fit a conic's extent).
Surface randomSurface(Rng& rng, double saMm, bool* aspheric) {
    Surface s;
    s.semiApertureMm = saMm;
    const double u = rng.uniform();
    double radius = 0.0;
    if (u < 0.10) radius = 0.0;                                              // plane
    else if (u < 0.25) radius = logUniform(rng, 3.0, 7.0);                  // nearly flat
    else if (u < 0.75) radius = saMm * uniform(rng, 1.5, 10.0);             // ordinary
    else radius = saMm * (1.0 + logUniform(rng, -6.0, -1.0));               // nearly a hemisphere
    if (chance(rng, 0.5)) radius = -radius;
    s.radiusMm = radius;

    if (radius != 0.0 && chance(rng, 0.3)) {
        const double v = rng.uniform();
        double k = v < 0.2 ? -1.0 : v < 0.6 ? -1.0 - logUniform(rng, -2.0, 1.5) : uniform(rng, -1.0, 5.0);
        // An ellipsoid (k > −1) must reach the clear aperture: (1 + k) c² r² < 1.
        const double c2r2 = saMm * saMm / (radius * radius);
        const double kMax = 1.0 / c2r2 - 1.0;
        if (k > -1.0 && k >= kMax) k = -1.0 + (kMax + 1.0) * uniform(rng, 0.0, 0.999);
        s.conic = k;
    }
    if (chance(rng, 0.25)) {
        *aspheric = true;
        const int terms = uniformInt(rng, 1, 4);
        const bool extreme = chance(rng, 0.05);
        for (int t = 0; t < terms; ++t) {
            const int i = uniformInt(rng, 0, kAsphereTerms - 1);
            // Sag contribution at the rim: up to ~3 mm, or up to 100 mm for an extreme surface.
            const double rimSagMm = extreme ? logUniform(rng, 0.5, 2.0) : logUniform(rng, -4.0, 0.5);
            s.asphere[i] = (chance(rng, 0.5) ? -1.0 : 1.0) * rimSagMm / std::pow(saMm, 2 * i + 4);
        }
    }
    return s;
}

std::string randomCoatingLine(Rng& rng) {
    if (chance(rng, 0.4))
        return "coating ar single n=" + exact(uniform(rng, 1.2, 1.6)) +
               " quarter_wave_nm=" + exact(uniform(rng, 380.0, 780.0));
    std::string line = "coating ar stack";
    const int layers = uniformInt(rng, 1, 6);
    for (int i = 0; i < layers; ++i)
        line += " " + exact(uniform(rng, 1.0, 2.5)) + ":" + exact(logUniform(rng, 0.0, 3.0));
    return line;
}

}  // namespace

GeneratedLens randomLens(Rng& rng) {
    GeneratedLens out;
    const int elements = uniformInt(rng, 1, 6);
    const int stopBefore = uniformInt(rng, 0, elements);  // the stop precedes this element
    const double sa0 = logUniform(rng, 0.0, 1.5);          // 1 mm … 32 mm

    std::vector<Row> rows;
    auto addStop = [&] {
        Row stop;
        stop.stop = true;
        stop.surface.isStop = true;
        stop.surface.semiApertureMm = sa0 * uniform(rng, 0.2, 1.2);
        rows.push_back(stop);
    };
    for (int e = 0; e < elements; ++e) {
        if (e == stopBefore) addStop();
        const double v = rng.uniform();
        const int pieces = v < 0.6 ? 1 : v < 0.9 ? 2 : 3;
        std::string previousGlass;
        // Every surface of an element (or cemented group) gets the same clear radius, which is then
        // also its mechanical edge, so that requiredGapMm (surfaces flat beyond their clear radius)
        // describes the same profile as the builder and the photon tracer (surfaces out to their
        // mechanical edge, then flat).
        const double groupSa = sa0 * uniform(rng, 0.6, 1.2);
        for (int p = 0; p <= pieces; ++p) {
            Row row;
            row.surface = randomSurface(rng, groupSa, &out.aspheric);
            row.planeAsZero = chance(rng, 0.5);
            if (p < pieces) {
                row.glassAfter = true;
                // Sometimes a cemented interface between two pieces of the same glass (no reflection).
                row.material = (p > 0 && chance(rng, 0.1)) ? previousGlass : randomGlass(rng);
                previousGlass = row.material;
            }
            if (chance(rng, 0.1)) {
                const char* names[] = {"none", "mgf2", "ar"};
                row.coating = names[uniformInt(rng, 0, 2)];
            }
            rows.push_back(row);
        }
    }
    if (stopBefore == elements) addStop();

    const double v0 = rng.uniform();
    const bool housingLine = v0 < 0.2;
    const double housingMarginMm = !housingLine ? 1.0 : v0 < 0.05 ? 0.0 : uniform(rng, 0.0, 3.0);

    // Thicknesses: just enough for the profiles not to cross, plus a margin that is sometimes zero
    // (surfaces touching at the rim) or tiny.
    std::vector<double> thickness(rows.size(), 0.0);
    for (size_t i = 0; i + 1 < rows.size(); ++i) {
        const double needed = requiredGapMm(rows[i], rows[i + 1]);
        const double v = rng.uniform();
        double margin;
        if (rows[i].glassAfter) margin = v < 0.1 ? logUniform(rng, -6.0, -3.0) : uniform(rng, 0.2, 8.0);
        else margin = v < 0.1 ? 0.0 : v < 0.2 ? logUniform(rng, -6.0, -3.0) : uniform(rng, 0.1, 15.0);
        thickness[i] = needed + margin;
    }
    const bool autoFocus = chance(rng, 0.3);
    if (!autoFocus) {
        const Row& last = rows.back();
        double deepest = 0.0;
        for (int k = 0; k <= 64; ++k) deepest = std::max(deepest, profileMm(last.surface, last.surface.semiApertureMm * k / 64));
        thickness.back() = deepest + uniform(rng, 0.5, 80.0);
    }

    // A zoom: one air space becomes a variable gap with two positions.
    int zoomRow = -1;
    double zoomTeleMm = 0.0;
    if (chance(rng, 0.1)) {
        std::vector<int> airRows;
        for (size_t i = 0; i + 1 < rows.size(); ++i)
            if (!rows[i].glassAfter) airRows.push_back(static_cast<int>(i));
        if (!airRows.empty()) {
            zoomRow = airRows[uniformInt(rng, 0, static_cast<int>(airRows.size()) - 1)];
            zoomTeleMm = thickness[zoomRow] + uniform(rng, 0.0, 10.0);
            out.zoom = true;
        }
    }

    std::string& t = out.text;
    t += "# generated by tests/stress/RandomLens.cpp\n";
    t += "name random lens\n";
    t += "focal_length_mm 50\n";
    if (out.zoom) {
        t += "zoom wide=30 tele=60\n";
        t += "gap g1 wide=" + exact(thickness[zoomRow]) + " tele=" + exact(zoomTeleMm) + "\n";
    }
    if (chance(rng, 0.6)) {
        const int blades = uniformInt(rng, 3, 16);
        const double v = rng.uniform();
        const double curvature = v < 0.3 ? 0.0 : v < 0.4 ? 1.0 : rng.uniform();
        t += "iris blades=" + std::to_string(blades) + " rotation_deg=" + exact(uniform(rng, 0.0, 360.0)) +
             " curvature=" + exact(curvature) + "\n";
    }
    {
        const double width = uniform(rng, 2.0, 60.0);
        const double v = rng.uniform();
        const double reflectance = v < 0.3 ? 0.0 : v < 0.4 ? 1.0 : uniform(rng, 0.0, 0.3);
        t += "sensor width_mm=" + exact(width) + " height_mm=" + exact(width * uniform(rng, 0.3, 1.0)) +
             " reflectance=" + exact(reflectance) + "\n";
    }
    if (housingLine) t += "housing margin_mm=" + exact(housingMarginMm) + "\n";
    if (chance(rng, 0.2)) t += "object_distance_mm " + exact(logUniform(rng, 1.7, 5.0)) + "\n";
    t += randomCoatingLine(rng) + "\n";
    {
        const char* defaults[] = {"none", "mgf2", "ar"};
        t += std::string("default_coating ") + defaults[uniformInt(rng, 0, 2)] + "\n";
    }
    t += "surfaces\n";
    for (size_t i = 0; i < rows.size(); ++i) {
        const Row& row = rows[i];
        const Surface& s = row.surface;
        std::string line;
        if (row.stop) line = "stop";
        else if (s.radiusMm == 0.0) line = row.planeAsZero ? "0" : "inf";
        else line = exact(s.radiusMm);
        if (static_cast<int>(i) == zoomRow) line += " g1";
        else if (i + 1 == rows.size() && autoFocus) line += " auto";
        else line += " " + exact(thickness[i]);
        line += " " + row.material + " " + exact(s.semiApertureMm);
        if (!row.stop) {
            if (s.conic != 0.0) line += " k=" + exact(s.conic);
            for (int a = 0; a < kAsphereTerms; ++a)
                if (s.asphere[a] != 0.0) line += " A" + std::to_string(2 * a + 4) + "=" + exact(s.asphere[a]);
            if (!row.coating.empty()) line += " coating=" + row.coating;
        }
        t += line + "\n";
    }
    out.rows = static_cast<int>(rows.size());
    return out;
}

}  // namespace flare::stress
