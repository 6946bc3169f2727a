#include "GhostCommands.h"

#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "LensOptions.h"
#include "Output.h"
#include "flare/core/Error.h"
#include "flare/ghosts/GhostAnalysis.h"
#include "flare/ghosts/GhostTable.h"
#include "flare/optics/LensSystem.h"
#include "flare/scene/Scene.h"

namespace flare::cli {

namespace {

struct GhostOptions {
    LensOptions lens;  // with a scene (.json), the scene supplies the lens and its state
    std::vector<double> fieldDeg;  // empty: 0,0 for a lens, the light's direction for a scene
    int light = 0;
    int order = 2;
    double wavelengthNm = 550.0;
    bool all = false;
    bool json = false;
    bool csv = false;
    bool noSensorGhosts = false;
};

std::string surfacesText(const GhostEstimate& g) {
    std::string text;
    for (int s : g.path.surfaceNumbers()) text += (text.empty() ? "" : "-") + std::to_string(s);
    return text;
}

bool isScene(const std::string& input) {
    return input.size() > 5 && input.compare(input.size() - 5, 5, ".json") == 0;
}

void run(const GhostOptions& o) {
    GhostAnalysisOptions options;
    options.order = o.order;
    options.wavelengthNm = o.wavelengthNm;
    options.includeSensor = !o.noSensorGhosts;
    std::optional<LensSystem> built;
    glm::dvec3 direction = directionFromFieldDeg(0.0, 0.0);
    if (isScene(o.lens.file)) {
        // A scene supplies the lens state, the light and the render settings; options on the
        // command line override the light's direction.
        const Scene scene = loadScene(o.lens.file);
        built.emplace(buildSceneLens(scene));
        if (o.light < 0 || o.light >= static_cast<int>(scene.lights.size()))
            throw InputError(o.lens.file, 0, "--light " + std::to_string(o.light) + ": the scene has " +
                                             std::to_string(scene.lights.size()) + " light(s)");
        direction = scene.lights[o.light].travelDirection();
        options.includeSensor = scene.render.includeSensorGhosts && !o.noSensorGhosts;
        options.keepShare = scene.render.pruneKeepShare;
        options.relativeThreshold = scene.render.pruneRelativeThreshold;
    } else {
        built.emplace(buildLens(o.lens));
    }
    const LensSystem& lens = *built;
    if (!o.fieldDeg.empty())
        direction = directionFromFieldDeg(o.fieldDeg[0], o.fieldDeg.size() > 1 ? o.fieldDeg[1] : 0.0);
    // Report the field as the angles at which the light is seen.
    const glm::dvec2 fieldDeg = fieldDegFromDirection(direction);
    const double fieldX = fieldDeg.x, fieldY = fieldDeg.y;
    const GhostReport report = analyseGhosts(lens, direction, options);

    std::vector<const GhostEstimate*> shown;
    for (const GhostEstimate& g : report.ghosts)
        if (o.all || !g.pruned) shown.push_back(&g);

    if (o.json) {
        std::cout << jsonText(ghostTableJson(lens, direction, options, report, o.all)) << "\n";
        return;
    }
    if (o.csv) {
        std::printf("surfaces,label,ghost_efl_mm,ghost_focus_mm,internal_focus,power_fraction,peak_irradiance_ratio,"
                    "x_min_mm,y_min_mm,x_max_mm,y_max_mm,pruned\n");
        for (const GhostEstimate* g : shown) {
            std::printf("%s,%s,%s,%s,%d,%.6e,%.6e,%.4f,%.4f,%.4f,%.4f,%d\n", surfacesText(*g).c_str(),
                        g->path.label().c_str(),
                        g->paraxial.eflMm ? std::to_string(*g->paraxial.eflMm).c_str() : "",
                        g->paraxial.focusFromSensorMm ? std::to_string(*g->paraxial.focusFromSensorMm).c_str() : "",
                        g->paraxial.internalFocus ? 1 : 0, g->powerFraction, g->peakIrradianceRatio,
                        g->footprintMinMm.x, g->footprintMinMm.y, g->footprintMaxMm.x, g->footprintMaxMm.y,
                        g->pruned ? 1 : 0);
        }
        return;
    }
    std::printf("%s: %zu ghosts of order %d (surface %d is the sensor), field (%.2f, %.2f) deg, %.1f nm\n",
                lens.name().c_str(), report.ghosts.size(), o.order, lens.surfaceCount() + 1, fieldX, fieldY,
                o.wavelengthNm);
    std::printf("direct image: %.4e of the entering power; all ghosts: %.4e; pruned: %d ghosts, %.3e\n\n",
                report.direct.powerFraction, report.totalGhostPowerFraction, report.prunedCount,
                report.prunedPowerFraction);
    std::printf("  %-12s %12s %14s %12s %12s  %s\n", "surfaces", "ghost EFL", "focus (mm)", "power", "peak E/E0",
                "footprint x,y (mm)");
    for (const GhostEstimate* g : shown) {
        char efl[32] = "afocal", focus[32] = "-";
        if (g->paraxial.eflMm) std::snprintf(efl, sizeof efl, "%.2f", *g->paraxial.eflMm);
        if (g->paraxial.focusFromSensorMm) std::snprintf(focus, sizeof focus, "%.2f%s", *g->paraxial.focusFromSensorMm,
                                                         g->paraxial.internalFocus ? "*" : "");
        std::printf("  %-12s %12s %14s %12.3e %12.3e  [%.1f, %.1f] x [%.1f, %.1f]%s\n", surfacesText(*g).c_str(), efl,
                    focus, g->powerFraction, g->peakIrradianceRatio, g->footprintMinMm.x, g->footprintMaxMm.x,
                    g->footprintMinMm.y, g->footprintMaxMm.y, g->pruned ? "  (pruned)" : "");
    }
    std::printf("\n* the ghost comes to a focus inside the lens\n");
}

}  // namespace

void addGhostCommands(CLI::App& app) {
    auto o = std::make_shared<GhostOptions>();
    CLI::App* ghosts = app.add_subcommand("ghosts", "enumerate and analyse the ghost paths of a lens for one light");
    addLensOptions(ghosts, o->lens, "lens file, shipped lens name, or scene (.json)");
    ghosts->add_option("--light", o->light, "with a scene: which light (0-based index)");
    ghosts->add_option("--field-deg", o->fieldDeg, "light's field angle X[,Y] in degrees")
        ->delimiter(',')
        ->expected(1, 2)
        ->check(CLI::Range(-89.0, 89.0));
    ghosts->add_option("--order", o->order, "number of reflections: 2 or 4")->check(CLI::IsMember({2, 4}));
    ghosts->add_option("--wavelength", o->wavelengthNm, "wavelength in nm (default 550)")->check(CLI::Range(300.0, 2000.0));
    ghosts->add_flag("--all", o->all, "list every enumerated path, pruned or not");
    ghosts->add_flag("--no-sensor-ghosts", o->noSensorGhosts, "leave out paths reflecting at the sensor");
    auto* json = ghosts->add_flag("--json", o->json, "print JSON");
    ghosts->add_flag("--csv", o->csv, "print CSV")->excludes(json);
    ghosts->callback([o] { run(*o); });
}

}  // namespace flare::cli
