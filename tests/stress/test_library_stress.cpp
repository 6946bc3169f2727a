// The full check of the lens library (ctest label `stress`, docs/lens-library.md), over every lens
// in lenses/library and every zoom position: the two-reflection ghost enumeration and its real-ray
// analysis for a light off axis, and a small spectral preview, with every power, footprint and
// pixel finite; then the numerical-stability stress runs of Stress.h (sequential traces, photon
// histories), fed with the library's lenses instead of random ones.
// Environment: FLARE_LIBRARY_LENSES=N checks only every k-th lens so that about N are checked, and
// always the lenses tagged "thesis" (the thesis reproduction's zoom, docs/thesis.md).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include "Stress.h"
#include "flare/core/Error.h"
#include "flare/core/Spectrum.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/ghosts/Preview.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/PupilGrid.h"

namespace flare::stress {
namespace {

std::vector<const LibraryLens*> lensesToCheck(const LensLibrary& library) {
    size_t step = 1;
    if (const char* n = std::getenv("FLARE_LIBRARY_LENSES"))
        step = std::max<size_t>(1, library.lenses().size() / std::max(1, std::atoi(n)));
    std::vector<const LibraryLens*> out;
    for (size_t i = 0; i < library.lenses().size(); ++i) {
        const LibraryLens& lens = library.lenses()[i];
        const bool thesis = std::find(lens.tags.begin(), lens.tags.end(), "thesis") != lens.tags.end();
        if (i % step == 0 || thesis) out.push_back(&lens);
    }
    return out;
}

bool finite(double v) { return std::isfinite(v); }

// The problem found with one lens at one zoom position, or "".
std::string fullCheck(const LensPrescription& prescription, const std::string& zoom) {
    const LensSystem lens = LensSystem::build(prescription, LensState{zoom, {}, {}});
    const ParaxialData para = analyseParaxial(lens, kLineDNm);
    // A light at a third of the sensor's half diagonal (at most 20°): off axis, inside the field.
    double fieldDeg = std::min(20.0, std::atan(lens.sensorHalfDiagonalMm() / 3.0 / std::abs(para.eflMm)) * 180.0 / M_PI);
    GhostAnalysisOptions options;
    options.coarseCells = 8;
    options.fineCells = 8;
    options.minLivePoints = 40;
    options.minPassingPoints = 16;
    options.maxRaysPerPath = 8192;
    // A library file's sensor may be larger than the field its lens covers (a small-format lens
    // given a 36 × 24 frame): where the whole field is vignetted, the light moves towards the
    // axis; on the axis the direct image must carry power.
    GhostReport report = analyseGhosts(lens, directionFromFieldDeg(fieldDeg, 0.0), options);
    for (int halving = 0; halving < 4 && !(report.direct.powerFraction > 0.0); ++halving) {
        fieldDeg = halving == 3 ? 0.0 : 0.5 * fieldDeg;
        report = analyseGhosts(lens, directionFromFieldDeg(fieldDeg, 0.0), options);
    }
    if (report.ghosts.empty()) return "no ghost path enumerated";
    if (!(report.direct.powerFraction > 0.0)) return "the direct image carries no power, even on the axis";
    for (const GhostEstimate& g : report.ghosts) {
        if (!finite(g.powerFraction) || g.powerFraction < 0.0 || !finite(g.peakIrradianceRatio) ||
            !finite(g.footprintMinMm.x) || !finite(g.footprintMaxMm.y) || (g.paraxial.focusFromSensorMm && !finite(*g.paraxial.focusFromSensorMm)))
            return "a ghost estimate is not finite";
    }
    if (!finite(report.totalGhostPowerFraction)) return "the total ghost power is not finite";
    PreviewLight light;
    light.direction = directionFromFieldDeg(fieldDeg, 0.0);
    light.spectrum = spectralQuadrature(Spectrum::blackbody(5778.0), 3);
    PreviewOptions preview;
    preview.widthPx = 72;
    preview.heightPx = 48;
    preview.minCells = 6;
    preview.maxCells = 12;
    const PreviewImage image = renderPreview(lens, light, report, preview);
    for (const XyzLayer* layer : {&image.direct, &image.ghosts})
        for (float v : layer->xyz)
            if (!std::isfinite(v) || v < 0.0f) return "a preview pixel of layer " + layer->name + " is not finite or negative";
    return "";
}

TEST(LibraryStress, GhostTablesAndPreviewsStayFinite) {
    const LensLibrary library = LensLibrary::load({std::string(FLARE_SOURCE_DIR) + "/lenses/library"});
    const std::vector<const LibraryLens*> lenses = lensesToCheck(library);
    ASSERT_FALSE(lenses.empty());
    std::mutex mutex;
    std::vector<std::string> failures;
    std::atomic<long> positions{0};
    const auto start = std::chrono::steady_clock::now();
    // Lenses in parallel; the analysis and the preview parallelise inside as well (TBB nests).
    tbb::parallel_for(size_t(0), lenses.size(), [&](size_t i) {
        const LibraryLens& entry = *lenses[i];
        std::string problem;
        try {
            const LensPrescription p = loadLensFile(entry.path);
            std::vector<std::string> zooms = entry.zoomPositions;
            if (zooms.empty()) zooms.push_back("");
            for (const std::string& zoom : zooms) {
                ++positions;
                if (std::string found = fullCheck(p, zoom); !found.empty())
                    problem += (zoom.empty() ? "" : zoom + ": ") + found + "; ";
            }
        } catch (const std::exception& e) {
            problem = e.what();
        }
        if (!problem.empty()) {
            const std::lock_guard lock(mutex);
            failures.push_back(entry.id + ": " + problem);
        }
    });
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << "library full check: " << lenses.size() << " lenses, " << positions << " zoom positions, "
              << failures.size() << " failed, " << seconds << " s\n";
    for (const std::string& f : failures) ADD_FAILURE() << f;
}

StressConfig libraryConfig(const LensLibrary& library) {
    StressConfig c;
    for (const LibraryLens* lens : lensesToCheck(library)) c.lensFiles.push_back(lens->path);
    c.lenses = static_cast<int>(c.lensFiles.size());
    c.raysPerLens = 128;
    c.photonsPerLens = 400;
    if (const char* out = std::getenv("FLARE_STRESS_OUT")) c.reproducerDir = out;
    return c;
}

TEST(LibraryStress, SequentialAndPhotonStressOverTheLibrary) {
    const LensLibrary library = LensLibrary::load({std::string(FLARE_SOURCE_DIR) + "/lenses/library"});
    const StressConfig config = libraryConfig(library);
    const StressReport sequential = runSequentialStress(config);
    std::cout << "---- sequential tracing, library ----\n" << sequential.summary();
    EXPECT_TRUE(sequential.failures.empty()) << sequential.summary();
    EXPECT_EQ(sequential.lensesBuilt, sequential.lensesTried) << sequential.summary();
    const StressReport photons = runPhotonStress(config);
    std::cout << "---- photon tracing, library ----\n" << photons.summary();
    EXPECT_TRUE(photons.failures.empty()) << photons.summary();
    EXPECT_EQ(photons.lensesBuilt, photons.lensesTried) << photons.summary();
}

}  // namespace
}  // namespace flare::stress
