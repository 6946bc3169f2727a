// Time against error of the ways the engine computes a flare: naive photon tracing (the seed
// thesis's Fresnel roulette), the guided hybrid (beams for the ghosts, photons elsewhere), the
// guided hybrid with photons only (the render before beams), and the deterministic preview; for several
// lenses and light positions, in one run on one machine (run by scripts/bench.sh).
//
// Cases: the double Gauss, the zoom at its wide and tele positions and the fisheye, two sun
// positions each (--list); by default six of the eight, at 192 px across (the zoom, with its
// 330-odd ghosts, at 48 px and with longer budgets); --quick: one case per lens at 96 px (48),
// smaller references and budgets, no finer preview (about 3 minutes).
//
// For each case (lens × zoom position × light):
//   reference  two independent guided renders (seeds 1001, 1002) run side by side until the
//              difference of their ghost layers puts the error of their mean below
//              --reference-error (or --reference-seconds runs out). The mean is the reference;
//              its own error E_ref (per metric, from the halves: ‖A − B‖ / (2‖ref‖)) is removed in
//              quadrature from every measured error, E² ≈ E_measured² − E_ref², and reported.
//              Cached under --cache (default out/bench-cache/) in a file keyed by a hash of this
//              executable (so any change of the engine's code invalidates it), the scene text and
//              the reference settings.
//   guided,    one progressive render each (seed 1); after geometrically spaced passes (×1.4)
//   photons,   the image is compared with the reference. Wall time = the renderer's construction
//   naive      (ghost analysis, guide masks) + the passes; the comparisons are not timed. Guided
//              and photons stop below the target/1.5 (or at --guided-seconds), naive at
//              --naive-seconds.
//   preview    once with the scene's settings (7 wavelengths) and once finer (16 wavelengths,
//              grid cells of 12 px instead of 24, up to 96 across): time = ghost analysis + preview
//              (the per-ghost powers come from a second, untimed render with per-ghost layers).
//
// Metrics (linear Rec.709 RGB, all pixels and channels; flare::compareImages):
//   flare  the whole image (direct + ghost + higher + scatter; the preview has only direct + ghost)
//   dg     direct + ghost layers (the like-for-like comparison for the preview)
//   ghost  the ghost layer
//   rel_l2 = ‖A − R‖/‖R‖, rel_mse = rel_l2² (ImageCompare.h: global normalisation);
//   ghost_power_err = Σ_g |P_g − R_g| / Σ_g R_g over every enumerated ghost path g, P from the
//   render's per-path tallies (the preview: each kept ghost's layer power; pruned ghosts count 0).
// The photon renders splat each photon bilinearly (a tent of radius 1 px, so their mean is the
// irradiance averaged over that tent); the preview fills the pixels whose centres lie inside each
// triangle (a point sample) but splats small triangles and the direct image bilinearly. No single
// filter makes the two alike everywhere, so every image is also compared after binning both it and
// the reference into blocks of `bin` × `bin` pixels (bin = max(2, width/48)): at that scale the
// kernels' sub-pixel difference no longer matters, and the comparison is fair to the preview
// ("_binned" columns, the reference's error recomputed from its binned halves).
//
// Outputs: --csv (every point), --summary (per case: time to --target on the ghost layer for
// both methods, extrapolated as t^(−1/2) where a method does not get there, the speed-up, the
// preview's time and errors), --strip DIR (PNG of the reference, the preview and both renders at
// equal time, all at the reference's exposure).
//
//   flare_time_error [--quick] [--cases a,b,...] [--csv F] [--summary F] [--strip DIR] [--cache DIR]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "flare/core/Spectrum.h"
#include "flare/film/ImageCompare.h"
#include "flare/film/ImageIO.h"
#include "flare/ghosts/Preview.h"
#include "flare/render/Render.h"
#include "flare/scene/SceneScattering.h"

using namespace flare;

namespace {

using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

struct Case {
    std::string name, lens, zoom;  // zoom: "" for a prime
    double fieldX, fieldY;
    bool heavy = false;  // the zoom: hundreds of ghosts, slow analysis; smaller images, longer budgets
};

// Three lenses, the zoom at two positions, two light positions each (one inside the frame, one at
// or beyond its edge, where ghosts are strongest and most spread).
const std::vector<Case> kCases = {
    {"dg-11-8", "double-gauss-50mm", "", 11.0, 8.0},  {"dg-15-0", "double-gauss-50mm", "", 15.0, 0.0},
    {"zw-11-8", "zoom-24-70mm", "wide", 11.0, 8.0, true},   {"zw-25-10", "zoom-24-70mm", "wide", 25.0, 10.0, true},
    {"zt-6-4", "zoom-24-70mm", "tele", 6.0, 4.0, true},     {"zt-12-0", "zoom-24-70mm", "tele", 12.0, 0.0, true},
    {"fe-11-8", "fisheye-16mm", "", 11.0, 8.0},      {"fe-45-20", "fisheye-16mm", "", 45.0, 20.0},
};

std::string sceneText(const Case& c, int w, int h) {
    std::ostringstream s;
    s << R"({ "lens": ")" << c.lens << '"';
    if (!c.zoom.empty()) s << R"(, "zoom": ")" << c.zoom << '"';
    s << R"(, "f_number": 4.0, "sensor": { "resolution": [)" << w << ',' << h << R"(] },
  "lights": [ { "type": "directional", "name": "sun", "field_deg": [)"
      << c.fieldX << ',' << c.fieldY << R"(], "angular_diameter_deg": 0.53,
                "spectrum": { "blackbody_k": 5778 }, "power": 1.0 } ],
  "render": { "preview_wavelengths": 7, "ghost_order": 2, "prune_keep_share": 0.999,
              "prune_relative_threshold": 1e-5, "sensor_ghosts": true } })";
    return s.str();
}

// ---- images --------------------------------------------------------------------------------

struct Layers {  // linear Rec.709 RGB, one per render layer (direct, ghost, higher, scatter)
    int w = 0, h = 0;
    std::vector<std::vector<float>> rgb;
    ImageLayer sum(std::initializer_list<int> which) const {
        ImageLayer out{"", w, h, std::vector<float>(static_cast<size_t>(w) * h * 3, 0.0f)};
        for (int l : which)
            for (size_t i = 0; i < out.rgb.size(); ++i) out.rgb[i] += rgb[l][i];
        return out;
    }
    ImageLayer flare() const { return sum({kLayerDirect, kLayerGhost, kLayerHigher, kLayerScatter}); }
    ImageLayer dg() const { return sum({kLayerDirect, kLayerGhost}); }
    ImageLayer ghost() const { return sum({kLayerGhost}); }
};

Layers layersOf(const Renderer& r, int w, int h) {
    Layers out{w, h, {}};
    for (int l = 0; l < kFixedLayerCount; ++l) out.rgb.push_back(rgbLayerFromXyz("", r.layerXyz(l), w, h).rgb);
    return out;
}

// Per enumerated ghost path (key: light index and label): mean power, W.
using GhostPowers = std::map<std::string, double>;
GhostPowers ghostPowersOf(const Renderer& r) {
    GhostPowers out;
    for (const PathTally& t : r.tallies())
        if (t.kind == PathTally::Kind::Ghost) out[std::to_string(t.light) + ":" + t.path.label()] = r.tallyPowerW(t);
    return out;
}

double ghostPowerError(const GhostPowers& a, const GhostPowers& ref) {
    double diff = 0.0, total = 0.0;
    for (const auto& [key, r] : ref) {
        const auto it = a.find(key);
        diff += std::abs((it == a.end() ? 0.0 : it->second) - r);
        total += r;
    }
    for (const auto& [key, p] : a)
        if (!ref.count(key)) diff += std::abs(p);
    return total > 0.0 ? diff / total : 0.0;
}

// Mean over blocks of k × k pixels (a partial block at the right or bottom edge is dropped).
ImageLayer binned(const ImageLayer& in, int k) {
    const int w = in.width / k, h = in.height / k;
    ImageLayer out{"", w, h, std::vector<float>(static_cast<size_t>(w) * h * 3, 0.0f)};
    for (int y = 0; y < h * k; ++y)
        for (int x = 0; x < w * k; ++x)
            for (int c = 0; c < 3; ++c)
                out.rgb[(static_cast<size_t>(y / k) * w + x / k) * 3 + c] +=
                    in.rgb[(static_cast<size_t>(y) * in.width + x) * 3 + c] / static_cast<float>(k * k);
    return out;
}

double relL2(const ImageLayer& a, const ImageLayer& b) { return compareImages(a, b).relL2.value_or(0.0); }

// ---- the reference, cached ---------------------------------------------------------------------

struct Reference {
    Layers mean, halfA;  // the mean of the halves, and the first half (the second is 2·mean − A)
    int bin = 2;
    double errDgBinned = 0, errGhostBinned = 0;  // of the binned mean, from the binned halves
    GhostPowers ghostPowers;
    double errFlare = 0, errDg = 0, errGhost = 0, errGhostPower = 0;  // of the mean, from the halves
    std::int64_t photons = 0;  // both halves
    double seconds = 0;        // both halves, wall time
};

std::uint64_t fnv1a(const void* data, size_t n, std::uint64_t h = 1469598103934665603ull) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

std::uint64_t executableHash() {
    std::ifstream in("/proc/self/exe", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return fnv1a(bytes.data(), bytes.size());
}

template <class T> void put(std::ostream& o, const T& v) { o.write(reinterpret_cast<const char*>(&v), sizeof v); }
template <class T> bool get(std::istream& i, T& v) { return static_cast<bool>(i.read(reinterpret_cast<char*>(&v), sizeof v)); }

void saveReference(const std::string& path, const Reference& r) {
    const std::string tmp = path + ".tmp";
    {
        std::ofstream o(tmp, std::ios::binary);
        put(o, r.mean.w), put(o, r.mean.h);
        for (const auto& l : r.mean.rgb) o.write(reinterpret_cast<const char*>(l.data()), l.size() * sizeof(float));
        for (const auto& l : r.halfA.rgb) o.write(reinterpret_cast<const char*>(l.data()), l.size() * sizeof(float));
        put(o, r.errFlare), put(o, r.errDg), put(o, r.errGhost), put(o, r.errGhostPower), put(o, r.photons), put(o, r.seconds);
        put(o, static_cast<std::uint64_t>(r.ghostPowers.size()));
        for (const auto& [k, v] : r.ghostPowers) {
            put(o, static_cast<std::uint64_t>(k.size()));
            o.write(k.data(), static_cast<std::streamsize>(k.size()));
            put(o, v);
        }
    }
    std::filesystem::rename(tmp, path);
}

std::optional<Reference> loadReference(const std::string& path, int w, int h) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return std::nullopt;
    Reference r;
    if (!get(in, r.mean.w) || !get(in, r.mean.h) || r.mean.w != w || r.mean.h != h) return std::nullopt;
    r.mean.rgb.assign(kFixedLayerCount, std::vector<float>(static_cast<size_t>(w) * h * 3));
    r.halfA = r.mean;
    for (auto& l : r.mean.rgb) in.read(reinterpret_cast<char*>(l.data()), static_cast<std::streamsize>(l.size() * sizeof(float)));
    for (auto& l : r.halfA.rgb) in.read(reinterpret_cast<char*>(l.data()), static_cast<std::streamsize>(l.size() * sizeof(float)));
    std::uint64_t n = 0;
    if (!get(in, r.errFlare) || !get(in, r.errDg) || !get(in, r.errGhost) || !get(in, r.errGhostPower) ||
        !get(in, r.photons) || !get(in, r.seconds) || !get(in, n))
        return std::nullopt;
    for (std::uint64_t i = 0; i < n; ++i) {
        std::uint64_t len = 0;
        double v = 0;
        if (!get(in, len) || len > 4096) return std::nullopt;
        std::string k(len, '\0');
        in.read(k.data(), static_cast<std::streamsize>(len));
        if (!get(in, v)) return std::nullopt;
        r.ghostPowers[k] = v;
    }
    return r;
}

RenderOptions optionsFor(const Scene& scene, const LensSystem& lens, RenderOptions::Mode mode, std::uint64_t seed) {
    RenderOptions o;
    o.mode = mode;
    o.seed = seed;
    o.analysis.order = scene.render.ghostOrder;
    o.analysis.includeSensor = scene.render.includeSensorGhosts;
    o.analysis.keepShare = scene.render.pruneKeepShare;
    o.analysis.relativeThreshold = scene.render.pruneRelativeThreshold;
    applySceneScattering(scene, lens, o);
    o.film.widthPx = scene.sensor.widthPx;
    o.film.heightPx = scene.sensor.heightPx;
    o.film.widthMm = lens.sensor().widthMm;
    o.film.heightMm = lens.sensor().heightMm;
    o.batchesPerPass = 16;  // 16 384 photons a pass: a fine ladder of measurement times
    return o;
}

// The binned reference's own error, from the binned halves.
void setBinnedErrors(Reference& ref) {
    ref.bin = std::max(2, ref.mean.w / 48);
    Layers b = ref.mean;
    for (size_t l = 0; l < b.rgb.size(); ++l)
        for (size_t i = 0; i < b.rgb[l].size(); ++i) b.rgb[l][i] = 2.0f * ref.mean.rgb[l][i] - ref.halfA.rgb[l][i];
    ref.errGhostBinned = 0.5 * relL2(binned(ref.halfA.ghost(), ref.bin), binned(b.ghost(), ref.bin));
    ref.errDgBinned = 0.5 * relL2(binned(ref.halfA.dg(), ref.bin), binned(b.dg(), ref.bin));
}

Reference computeReference(const Scene& scene, const LensSystem& lens, double targetError, double maxSeconds) {
    const int w = scene.sensor.widthPx, h = scene.sensor.heightPx;
    const auto start = Clock::now();
    Renderer a(lens, scene.lights, optionsFor(scene, lens, RenderOptions::Mode::Guided, 1001));
    Renderer b(lens, scene.lights, optionsFor(scene, lens, RenderOptions::Mode::Guided, 1002));
    Reference ref;
    int nextCheck = 4;
    while (true) {
        a.runPass();
        b.runPass();
        if (a.statistics().passes < nextCheck && seconds(start) < maxSeconds) continue;
        nextCheck = static_cast<int>(nextCheck * 1.5) + 1;
        const Layers la = layersOf(a, w, h), lb = layersOf(b, w, h);
        // ‖A − B‖ ≈ √2 E_half ‖ref‖, and the mean of the halves has E_half/√2 = ‖A − B‖/(2‖ref‖).
        ref.errGhost = 0.5 * relL2(la.ghost(), lb.ghost());
        const double elapsed = seconds(start);
        std::fprintf(stderr, "#   reference: %.3g photons per half, %.1f s, ghost-layer error of the mean %.4f\n",
                     static_cast<double>(a.statistics().photons), elapsed, ref.errGhost);
        if (ref.errGhost > targetError && elapsed < maxSeconds) continue;
        ref.errFlare = 0.5 * relL2(la.flare(), lb.flare());
        ref.errDg = 0.5 * relL2(la.dg(), lb.dg());
        ref.mean = la;
        ref.halfA = la;
        for (size_t l = 0; l < ref.mean.rgb.size(); ++l)
            for (size_t i = 0; i < ref.mean.rgb[l].size(); ++i) ref.mean.rgb[l][i] = 0.5f * (la.rgb[l][i] + lb.rgb[l][i]);
        const GhostPowers pa = ghostPowersOf(a), pb = ghostPowersOf(b);
        for (const auto& [k, v] : pa) ref.ghostPowers[k] = 0.5 * (v + pb.at(k));
        ref.errGhostPower = 0.5 * ghostPowerError(pa, pb);
        ref.photons = a.statistics().photons + b.statistics().photons;
        ref.seconds = elapsed;
        return ref;
    }
}

// ---- measuring ---------------------------------------------------------------------------------

struct Point {
    std::string method;
    double seconds = 0;
    std::int64_t photons = 0;
    double flare = 0, dg = 0, ghost = 0, ghostPower = 0;  // corrected rel. L2; ghost-power error as measured
    double flareMeasured = 0, ghostMeasured = 0;
    double dgBinned = 0, ghostBinned = 0;  // corrected, after binning both images
};

double corrected(double measured, double refError) {
    return std::sqrt(std::max(0.0, measured * measured - refError * refError));
}

Point measure(const std::string& method, double t, std::int64_t photons, const ImageLayer& flare, const ImageLayer& dg,
              const ImageLayer& ghost, double ghostPower, const Reference& ref) {
    Point p{method, t, photons};
    p.flareMeasured = relL2(flare, ref.mean.flare());
    p.ghostMeasured = relL2(ghost, ref.mean.ghost());
    p.flare = corrected(p.flareMeasured, ref.errFlare);
    p.dg = corrected(relL2(dg, ref.mean.dg()), ref.errDg);
    p.ghost = corrected(p.ghostMeasured, ref.errGhost);
    p.ghostPower = ghostPower;
    p.dgBinned = corrected(relL2(binned(dg, ref.bin), binned(ref.mean.dg(), ref.bin)), ref.errDgBinned);
    p.ghostBinned = corrected(relL2(binned(ghost, ref.bin), binned(ref.mean.ghost(), ref.bin)), ref.errGhostBinned);
    return p;
}

struct Crossing {
    double seconds = 0;
    std::string kind;  // interpolated, first-point (an upper bound), extrapolated (t^-1/2 fit)
    double slope = 0;  // fitted log–log slope over the last decade of time (free fit)
};

// Time at which the ghost-layer error reaches `target`.
Crossing timeTo(const std::vector<Point>& pts, double target) {
    Crossing c;
    // Free log–log slope over the last decade (for the record: the Monte Carlo law is −1/2).
    const double tLast = pts.back().seconds;
    double sx = 0, sy = 0, sxx = 0, sxy = 0, n = 0, sumLogC = 0;
    for (const Point& p : pts) {
        if (p.seconds < tLast / 10.0 || p.ghost <= 0.0) continue;
        const double x = std::log(p.seconds), y = std::log(p.ghost);
        sx += x, sy += y, sxx += x * x, sxy += x * y, n += 1;
        sumLogC += y + 0.5 * x;
    }
    c.slope = n >= 2 && n * sxx - sx * sx > 0 ? (n * sxy - sx * sy) / (n * sxx - sx * sx) : 0.0;
    for (size_t i = 0; i < pts.size(); ++i) {
        if (pts[i].ghost > target) continue;
        if (i == 0) return {pts[0].seconds, "first-point", c.slope};
        const Point &a = pts[i - 1], &b = pts[i];
        const double s = std::log(b.ghost / a.ghost) / std::log(b.seconds / a.seconds);
        c.seconds = a.seconds * std::exp(std::log(target / a.ghost) / s);
        c.kind = "interpolated";
        return c;
    }
    // Not reached: error = C t^(−1/2), C fitted (in log space) over the last decade of time.
    const double logC = n > 0 ? sumLogC / n : std::log(pts.back().ghost) + 0.5 * std::log(tLast);
    c.seconds = std::exp(2.0 * (logC - std::log(target)));
    c.kind = "extrapolated";
    return c;
}

PreviewLight previewLightOf(const LightSpec& spec, int wavelengths) {
    PreviewLight light;
    light.direction = spec.travelDirection();
    light.spectrum = spectralQuadrature(toSpectrum(spec.spectrum), wavelengths);
    light.irradiance = spec.power;
    light.angularDiameterDeg = spec.angularDiameterDeg;
    return light;
}

void writeStripPng(const std::string& path, const ImageLayer& image, double exposure) {
    if (!path.empty()) writePng(path, image, exposure);
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"time against error: naive and guided photon tracing and the preview, several lenses and lights"};
    bool quick = false;
    std::string csvPath = "out/bench/timing.csv", summaryPath = "out/bench/summary.csv", stripDir = "out/bench/strip",
                cacheDir = "out/bench-cache";
    std::vector<std::string> caseNames;
    int width = 0, heavyWidth = 48;
    double target = 0.05, referenceError = 0, referenceSeconds = 0, naiveSeconds = 0, guidedSeconds = 0;
    double heavyReferenceSeconds = 0, heavyGuidedSeconds = 0;
    bool noFinePreview = false;
    app.add_flag("--quick", quick, "one light per lens, 96 px wide, smaller references and budgets (< 5 min)");
    app.add_option("--cases", caseNames, "cases to run (default: all; --quick: the first light of each lens)")->delimiter(',');
    app.add_option("--csv", csvPath, "every measured point");
    app.add_option("--summary", summaryPath, "one line per case");
    app.add_option("--strip", stripDir, "PNGs of the renders at equal time ('' = none)");
    app.add_option("--cache", cacheDir, "reference cache directory");
    app.add_option("--width", width, "image width in pixels (height from the sensor's aspect); default 192, quick 96");
    app.add_option("--target", target, "ghost-layer relative L2 error to reach");
    app.add_option("--reference-error", referenceError, "reference: stop when its ghost-layer error is below");
    app.add_option("--reference-seconds", referenceSeconds, "reference: time limit (both halves)");
    app.add_option("--naive-seconds", naiveSeconds, "time budget of the naive method");
    app.add_option("--guided-seconds", guidedSeconds, "time budget of the guided method");
    app.add_option("--heavy-width", heavyWidth, "image width of the zoom's cases");
    app.add_option("--heavy-reference-seconds", heavyReferenceSeconds, "reference time limit of the zoom's cases");
    app.add_option("--heavy-guided-seconds", heavyGuidedSeconds, "guided time budget of the zoom's cases");
    app.add_flag("--no-fine-preview", noFinePreview, "skip the finer preview (--quick skips it)");
    app.add_flag_callback("--list", [] {
        for (const Case& c : kCases) std::printf("%s\n", c.name.c_str());
        std::exit(0);
    }, "list the cases");
    CLI11_PARSE(app, argc, argv);
    if (width <= 0) width = quick ? 96 : 192;
    if (referenceError <= 0) referenceError = quick ? 0.025 : 0.012;
    if (referenceSeconds <= 0) referenceSeconds = quick ? 25.0 : 120.0;
    if (naiveSeconds <= 0) naiveSeconds = quick ? 8.0 : 60.0;
    if (guidedSeconds <= 0) guidedSeconds = quick ? 10.0 : 60.0;
    if (heavyReferenceSeconds <= 0) heavyReferenceSeconds = quick ? 45.0 : 240.0;
    if (heavyGuidedSeconds <= 0) heavyGuidedSeconds = quick ? 15.0 : 90.0;
    if (quick) noFinePreview = true;
    std::vector<Case> cases;
    if (caseNames.empty()) {
        for (const Case& c : kCases)
            if (quick ? c.name == "dg-11-8" || c.name == "zt-6-4" || c.name == "fe-11-8"
                      : c.name != "zw-25-10" && c.name != "zt-12-0")
                cases.push_back(c);
    } else {
        for (const std::string& n : caseNames) {
            const auto it = std::find_if(kCases.begin(), kCases.end(), [&](const Case& c) { return c.name == n; });
            if (it == kCases.end()) {
                std::fprintf(stderr, "unknown case '%s' (--list lists them)\n", n.c_str());
                return 2;
            }
            cases.push_back(*it);
        }
    }

    for (const std::string& p : {csvPath, summaryPath})
        if (const auto dir = std::filesystem::path(p).parent_path(); !dir.empty()) std::filesystem::create_directories(dir);
    if (!stripDir.empty()) std::filesystem::create_directories(stripDir);
    std::filesystem::create_directories(cacheDir);
    const std::uint64_t exeHash = executableHash();

    std::ofstream csv(csvPath), summary(summaryPath);
    csv << "case,lens,zoom,field_x_deg,field_y_deg,width,height,method,seconds,photons,flare_rel_l2,flare_rel_mse,dg_rel_l2,"
           "dg_rel_mse,ghost_rel_l2,ghost_rel_mse,ghost_power_err,flare_rel_l2_measured,ghost_rel_l2_measured,bin,"
           "dg_rel_l2_binned,ghost_rel_l2_binned\n";
    summary << "case,lens,zoom,field_x_deg,field_y_deg,width,height,kept_ghosts,ref_photons,ref_seconds,ref_flare_err,"
               "ref_ghost_err,ref_ghost_power_err,target,guided_t,guided_t_kind,guided_slope,naive_t,naive_t_kind,"
               "naive_slope,speedup,naive_last_s,naive_last_ghost_err,preview_s,preview_flare_err,preview_dg_err,"
               "preview_ghost_err,preview_binned_dg_err,preview_binned_ghost_err,preview_ghost_power_err,"
               "preview_fine_s,preview_fine_binned_ghost_err,preview_fine_ghost_power_err,strip_guided_s,strip_naive_s,"
               "strip_guided_ghost_err,strip_naive_ghost_err,photons_t,photons_t_kind,photons_slope,speedup_over_photons\n";
    std::fprintf(stderr, "# %zu case(s), %d px wide, target %.3g on the ghost layer, naive budget %.3g s\n", cases.size(),
                 width, target, naiveSeconds);

    for (const Case& c : cases) {
        const auto caseStart = Clock::now();
        // The three lenses have 36 × 24 mm sensors (the scene parser refuses pixels that are not square).
        const int caseWidth = c.heavy ? heavyWidth : width;
        const int height = caseWidth * 2 / 3;
        const std::string text = sceneText(c, caseWidth, height);
        const Scene scene = parseSceneText(text, "benchmark case " + c.name, "");
        const LensSystem lens = buildSceneLens(scene);
        const int w = caseWidth, h = height;
        const double refSeconds = c.heavy ? heavyReferenceSeconds : referenceSeconds;
        const double guidedBudget = c.heavy ? heavyGuidedSeconds : guidedSeconds;
        std::fprintf(stderr, "# case %s: %s%s%s, sun at (%g, %g) deg, %dx%d px\n", c.name.c_str(), c.lens.c_str(),
                     c.zoom.empty() ? "" : " at ", c.zoom.c_str(), c.fieldX, c.fieldY, w, h);
        const int bin = std::max(2, w / 48);  // as setBinnedErrors
        auto row = [&](const Point& p) {
            char buf[512];
            std::snprintf(buf, sizeof buf, "%s,%s,%s,%g,%g,%d,%d,%s,%.4f,%lld,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%d,%.6g,%.6g\n",
                          c.name.c_str(), c.lens.c_str(), c.zoom.c_str(), c.fieldX, c.fieldY, w, h, p.method.c_str(),
                          p.seconds, static_cast<long long>(p.photons), p.flare, p.flare * p.flare, p.dg, p.dg * p.dg, p.ghost,
                          p.ghost * p.ghost, p.ghostPower, p.flareMeasured, p.ghostMeasured, bin, p.dgBinned, p.ghostBinned);
            csv << buf;
            csv.flush();
        };

        // Reference (cached).
        char key[64];
        std::uint64_t hash = fnv1a(text.data(), text.size(), exeHash);
        const double refParams[2] = {referenceError, refSeconds};
        hash = fnv1a(refParams, sizeof refParams, hash);
        std::snprintf(key, sizeof key, "%016llx", static_cast<unsigned long long>(hash));
        const std::string cachePath = cacheDir + "/" + c.name + "-" + key + ".ref";
        std::optional<Reference> cached = loadReference(cachePath, w, h);
        if (cached) std::fprintf(stderr, "#   reference from %s\n", cachePath.c_str());
        Reference ref = cached ? *cached : computeReference(scene, lens, referenceError, refSeconds);
        if (!cached) saveReference(cachePath, ref);
        setBinnedErrors(ref);
        std::fprintf(stderr, "#   reference: %.3g photons, %.1f s; its own error: flare %.4f, ghost %.4f, ghost powers %.4f\n",
                     static_cast<double>(ref.photons), ref.seconds, ref.errFlare, ref.errGhost, ref.errGhostPower);
        Point refRow{"reference", ref.seconds, ref.photons, ref.errFlare, ref.errDg, ref.errGhost, ref.errGhostPower,
                     ref.errFlare, ref.errGhost, ref.errDgBinned, ref.errGhostBinned};
        row(refRow);
        const double exposure = 0.25 * autoExposure(ref.mean.ghost());

        // Preview: plain, and finer (more wavelengths, smaller grid cells).
        const LightSpec& spec = scene.lights.front();
        GhostAnalysisOptions analysis = optionsFor(scene, lens, RenderOptions::Mode::Guided, 1).analysis;
        Point previewPoint;
        double previewFineSeconds = 0, previewFineBinnedGhost = 0, previewFinePower = 0;
        int kept = 0;
        for (int fine = 0; fine < (noFinePreview ? 1 : 2); ++fine) {
            PreviewOptions po;
            po.widthPx = w;
            po.heightPx = h;
            if (fine) po.pixelsPerCell = 12.0, po.maxCells = 96;
            const PreviewLight light = previewLightOf(spec, fine ? 16 : scene.render.previewWavelengths);
            const auto t0 = Clock::now();
            const GhostReport report = analyseGhosts(lens, light.direction, analysis);
            const PreviewImage image = renderPreview(lens, light, report, po);
            const double t = seconds(t0);
            // Per-ghost powers (untimed: a second render with one layer per ghost).
            po.perGhostLayers = true;
            const PreviewImage layered = renderPreview(lens, light, report, po);
            GhostPowers powers;
            const double entering = spec.power * 1e-6 * report.enteringAreaMm2;  // W/m² × mm² → W
            kept = 0;
            for (const GhostEstimate& g : report.ghosts) {
                if (g.pruned) continue;
                powers["0:" + g.path.label()] =
                    layerPowerFraction(layered, layered.perGhost[kept++], report, light.irradiance) * entering;
            }
            const double powerErr = ghostPowerError(powers, ref.ghostPowers);
            const ImageLayer direct = rgbLayerFromXyz("", image.direct.xyz, w, h), ghost = rgbLayerFromXyz("", image.ghosts.xyz, w, h);
            ImageLayer dg = direct;
            for (size_t i = 0; i < dg.rgb.size(); ++i) dg.rgb[i] += ghost.rgb[i];
            const std::string name = fine ? "preview-fine" : "preview";
            const Point p = measure(name, t, 0, dg, dg, ghost, powerErr, ref);
            row(p);
            std::fprintf(stderr, "#   %s: %.3f s, %d ghosts; ghost layer %.4f (binned %d×%d: %.4f), direct+ghost %.4f (binned %.4f), "
                         "ghost powers %.4f\n", name.c_str(), t, kept, p.ghost, ref.bin, ref.bin, p.ghostBinned, p.dg,
                         p.dgBinned, powerErr);
            if (fine) {
                previewFineSeconds = t, previewFineBinnedGhost = p.ghostBinned, previewFinePower = powerErr;
            } else {
                previewPoint = p;
                if (!stripDir.empty()) writeStripPng(stripDir + "/" + c.name + "-preview.png", dg, exposure);
            }
        }
        if (!stripDir.empty()) writeStripPng(stripDir + "/" + c.name + "-reference.png", ref.mean.flare(), exposure);

        // Guided, then naive: progressive renders measured at geometrically spaced passes.
        // Methods: 0 guided (beams and photons, the default), 1 naive, 2 photons (guided photons
        // only: the guided render before beams).
        Crossing crossing[3];
        double stripT = 0, stripGuidedT = 0, stripNaiveT = 0, stripGuidedErr = 0, stripNaiveErr = 0;
        double naiveLastT = 0, naiveLastErr = 0;
        for (int m = 0; m < 3; ++m) {
            const bool guided = m == 0, photonsOnly = m == 2;
            const std::string name = guided ? "guided" : photonsOnly ? "photons" : "naive";
            const RenderOptions::Mode mode = guided        ? RenderOptions::Mode::Guided
                                             : photonsOnly ? RenderOptions::Mode::GuidedPhotons
                                                           : RenderOptions::Mode::Naive;
            const auto t0 = Clock::now();
            Renderer r(lens, scene.lights, optionsFor(scene, lens, mode, 1));
            double timed = seconds(t0);
            std::vector<Point> points;
            std::vector<ImageLayer> snapshots;  // guided: the flare image at each point, for the strip
            bool stripDone = false;
            int nextMeasure = 1;
            while (true) {
                const auto tp = Clock::now();
                r.runPass();
                timed += seconds(tp);
                if (r.statistics().passes < nextMeasure) continue;
                nextMeasure = std::max(nextMeasure + 1, static_cast<int>(nextMeasure * 1.4));
                const Layers l = layersOf(r, w, h);
                const Point p = measure(name, timed, r.statistics().photons, l.flare(), l.dg(), l.ghost(),
                                        ghostPowerError(ghostPowersOf(r), ref.ghostPowers), ref);
                points.push_back(p);
                row(p);
                if (guided) snapshots.push_back(l.flare());
                if (m == 1 && !stripDone && timed >= stripT) {
                    stripDone = true;
                    stripNaiveT = timed, stripNaiveErr = p.ghost;
                    if (!stripDir.empty()) writeStripPng(stripDir + "/" + c.name + "-naive.png", l.flare(), exposure);
                }
                const double budget = m == 1 ? naiveSeconds : guidedBudget;
                const double stopBelow = m == 1 ? 0.0 : target / 1.5;
                if (p.ghost <= stopBelow || timed > budget) {
                    // Naive ran out of time before the strip's time: show its last image.
                    if (m == 1 && !stripDone) {
                        stripNaiveT = timed, stripNaiveErr = p.ghost;
                        if (!stripDir.empty()) writeStripPng(stripDir + "/" + c.name + "-naive.png", l.flare(), exposure);
                    }
                    break;
                }
            }
            crossing[m] = timeTo(points, target);
            std::fprintf(stderr, "#   %s: %zu points, last %.2f s (%.3g photons) ghost %.4f flare %.4f; time to %.3g: %.3g s (%s), "
                         "slope %.2f\n", name.c_str(), points.size(), points.back().seconds,
                         static_cast<double>(points.back().photons), points.back().ghost, points.back().flare, target,
                         crossing[m].seconds, crossing[m].kind.c_str(), crossing[m].slope);
            if (guided) {
                // The strip's time: the guided render's first point at or past its time to the target.
                size_t i = 0;
                while (i + 1 < points.size() && points[i].seconds < crossing[0].seconds) ++i;
                stripT = stripGuidedT = points[i].seconds, stripGuidedErr = points[i].ghost;
                if (!stripDir.empty()) writeStripPng(stripDir + "/" + c.name + "-guided.png", snapshots[i], exposure);
            } else if (m == 1) {
                naiveLastT = points.back().seconds, naiveLastErr = points.back().ghost;
            }
        }

        char buf[2048];
        std::snprintf(buf, sizeof buf,
                      "%s,%s,%s,%g,%g,%d,%d,%d,%lld,%.2f,%.5f,%.5f,%.5f,%g,%.4g,%s,%.3f,%.4g,%s,%.3f,%.4g,%.3f,%.5f,%.4f,%.5f,"
                      "%.5f,%.5f,%.5f,%.5f,%.5f,%.4f,%.5f,%.5f,%.3f,%.3f,%.5f,%.5f,%.4g,%s,%.3f,%.3f\n",
                      c.name.c_str(), c.lens.c_str(), c.zoom.c_str(), c.fieldX, c.fieldY, w, h, kept,
                      static_cast<long long>(ref.photons), ref.seconds, ref.errFlare, ref.errGhost, ref.errGhostPower, target,
                      crossing[0].seconds, crossing[0].kind.c_str(), crossing[0].slope, crossing[1].seconds,
                      crossing[1].kind.c_str(), crossing[1].slope, crossing[1].seconds / crossing[0].seconds, naiveLastT,
                      naiveLastErr, previewPoint.seconds, previewPoint.flare, previewPoint.dg, previewPoint.ghost, previewPoint.dgBinned,
                      previewPoint.ghostBinned, previewPoint.ghostPower, previewFineSeconds, previewFineBinnedGhost, previewFinePower,
                      stripGuidedT, stripNaiveT, stripGuidedErr, stripNaiveErr, crossing[2].seconds,
                      crossing[2].kind.c_str(), crossing[2].slope, crossing[2].seconds / crossing[0].seconds);
        summary << buf;
        summary.flush();
        std::fprintf(stderr, "#   => speed-up of guided over naive at %.3g: %.0fx (naive %s), over guided photons %.1fx (%s); "
                     "case took %.0f s\n", target, crossing[1].seconds / crossing[0].seconds, crossing[1].kind.c_str(),
                     crossing[2].seconds / crossing[0].seconds, crossing[2].kind.c_str(), seconds(caseStart));
    }
    return 0;
}
