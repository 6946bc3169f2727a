// Shared pieces of the renderer tests: a lens whose ghosts naive tracing resolves in a unit test,
// the render options a scene implies, and the guided-against-naive agreement check.
#pragma once

#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>

#include <gtest/gtest.h>

#include "TestUtil.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneScattering.h"

namespace flare::test {

// An uncoated air-spaced doublet (f ≈ 50 mm): its ghosts are bright (R ≈ 4–6 % per surface), so
// naive photon tracing converges on them in a unit test.
inline constexpr const char* kUncoatedDoublet = R"(name test doublet
focal_length_mm 50
sensor width_mm=36 height_mm=24 reflectance=0.02
surfaces
   35.0    6.0    n=1.62     13
  -90.0    3.0    air        13
   stop    4.0    air        9
  -60.0    2.5    n=1.72     11
  400.0    auto   air        11
)";

// kUncoatedDoublet written as doublet.lens into this process's scratch folder `folder`; its path.
inline std::string writeUncoatedDoublet(const std::string& folder) {
    const auto dir = processTempDir(folder);
    std::filesystem::create_directories(dir);
    const std::string lens = (dir / "doublet.lens").string();
    std::ofstream(lens) << kUncoatedDoublet;
    return lens;
}

// The film the scene's sensor gives and the scene's scattering, in the given mode.
inline RenderOptions sceneRenderOptions(const Scene& scene, const LensSystem& lens, RenderOptions::Mode mode,
                                        std::uint64_t seed = 4) {
    RenderOptions o;
    o.mode = mode;
    o.seed = seed;
    // Small passes: the tests want many passes (their spread, or their replicates', is the
    // standard error) more than large ones.
    o.batchesPerPass = 16;
    o.beamsPerPass = 32;
    o.film.widthPx = scene.sensor.widthPx;
    o.film.heightPx = scene.sensor.heightPx;
    o.film.widthMm = lens.sensor().widthMm;
    o.film.heightMm = lens.sensor().heightMm;
    applySceneScattering(scene, lens, o);
    return o;
}

// Guided and naive estimate the same power in each of `layers`: a two-sided z-test per layer on
// the difference of their tallies, Bonferroni-corrected to the family-wise level alpha.
inline void expectGuidedAgreesWithNaive(const Renderer& guided, const Renderer& naive, std::initializer_list<int> layers,
                                        double alpha = 1e-3) {
    const double z = normalTwoSidedCritical(alpha / static_cast<double>(layers.size()));
    for (int l : layers) {
        const PathTally& a = guided.layerTallies()[l];
        const PathTally& b = naive.layerTallies()[l];
        const double sigma = std::hypot(guided.tallyStandardErrorW(a), naive.tallyStandardErrorW(b));
        EXPECT_LT(std::abs(guided.tallyPowerW(a) - naive.tallyPowerW(b)), z * sigma)
            << renderLayerName(l) << ": guided " << guided.tallyPowerW(a) << ", naive " << naive.tallyPowerW(b);
    }
}

}  // namespace flare::test
