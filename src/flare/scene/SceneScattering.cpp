#include "flare/scene/SceneScattering.h"

#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>

#include "flare/core/Error.h"
#include "flare/optics/LensFile.h"
#include "flare/photons/CoverageMask.h"
#include "flare/photons/VolumeGrid.h"

namespace flare {

void applySceneScattering(const Scene& scene, const LensSystem& lens, RenderOptions& options) {
    const ScatteringSettings& s = scene.scattering;
    // The lens file's scattering, which the scene overrides. (Read again here: a LensSystem keeps
    // no prescription, and the file is small.)
    const LensPrescription prescription = scene.lens.empty() ? LensPrescription{} : loadLens(scene.lens);
    const FinishSpec housing = s.housing.value_or(prescription.housingFinish.value_or(FinishSpec{}));
    const FinishSpec edges = s.edges.value_or(prescription.edgeFinish.value_or(FinishSpec{}));
    const FinishSpec iris = s.iris.value_or(prescription.irisFinish.value_or(FinishSpec{}));
    InteriorMaterials& m = options.materials;
    m.housingAlbedo = housing.diffuse, m.housingGlossy = housing.glossy;
    m.edgeAlbedo = edges.diffuse, m.edgeGlossy = edges.glossy;
    m.irisAlbedo = iris.diffuse, m.irisGlossy = iris.glossy;
    m.glossExponent = s.glossExponent.value_or(prescription.glossExponent.value_or(InteriorMaterials{}.glossExponent));
    const int n = lens.surfaceCount();
    auto surfaceIndex = [&](int number, int line, const char* what) {
        if (number > n)
            throw InputError(scene.sourceFile, line,
                             std::string(what) + ": surface " + std::to_string(number) + " does not exist (the lens has " +
                                 std::to_string(n) + " surfaces, counting the stop)");
        if (lens.surface(number - 1).isStop || !lens.isReflecting(number - 1))
            throw InputError(scene.sourceFile, line,
                             std::string(what) + ": surface " + std::to_string(number) +
                                 " is not an interface between two media (the stop, or equal media)");
        if (!lens.mediumBefore(number - 1).isAir() && !lens.mediumBefore(number).isAir())
            throw InputError(scene.sourceFile, line,
                             std::string(what) + ": surface " + std::to_string(number) +
                                 " is a cemented interface (glass on both sides): nothing can settle there");
        return number - 1;
    };
    // A mask's file errors name the scene and the key too: the user wrote the path there.
    auto loadMask = [&](const MaskSpec& spec, int surface) -> std::shared_ptr<const CoverageMask> {
        if (spec.file.empty()) return nullptr;
        CoverageMask mask;
        try {
            mask = CoverageMask::load(spec.file);
        } catch (const InputError& e) {
            throw InputError(scene.sourceFile, spec.line,
                             spec.keyPath + ": cannot use the mask image '" + spec.file + "': " + e.problem());
        }
        const double widthMm = spec.widthMm.value_or(2.0 * lens.surface(surface).semiApertureMm);
        const double heightMm = spec.heightMm.value_or(widthMm * mask.heightPx() / mask.widthPx());
        mask.place(widthMm, heightMm, spec.centreMm);
        return std::make_shared<const CoverageMask>(std::move(mask));
    };
    options.contamination.clear();
    // The same file built `lens`, so its rows are the lens's surfaces; anything else is a bug
    // (say, a scene whose lens changed between the two reads), not something to skip silently.
    if (!scene.lens.empty() && static_cast<int>(prescription.rows.size()) != n)
        throw std::logic_error("applySceneScattering: " + scene.lens + " has " + std::to_string(prescription.rows.size()) +
                               " surfaces, the lens built from it " + std::to_string(n));
    const bool lensDirt = std::any_of(prescription.rows.begin(), prescription.rows.end(),
                                      [](const PrescriptionRow& row) { return row.dust || row.grease; });
    if (!s.dust.empty() || !s.grease.empty() || lensDirt) options.contamination.assign(n, SurfaceContamination{});
    // The lens file's dust and grease first (its parser checked the surfaces), then the scene's,
    // whose entries replace them surface by surface.
    if (lensDirt)
        for (int k = 0; k < n; ++k) {
            SurfaceContamination& c = options.contamination[k];
            if (const auto& d = prescription.rows[k].dust) {
                c.dustCoverage = d->coverage, c.dustAlbedo = d->albedo, c.dustDiameterUm = d->diameterUm;
                c.dustDiameterSigma = d->diameterSigma;
            }
            if (const auto& g = prescription.rows[k].grease) c.greaseCoverage = g->coverage, c.greaseRoughness = g->roughness;
        }
    for (const DustSpec& d : s.dust) {
        const int k = surfaceIndex(d.surface, d.line, "dust");
        SurfaceContamination& c = options.contamination[k];
        c.dustCoverage = d.coverage, c.dustAlbedo = d.albedo, c.dustDiameterUm = d.diameterUm;
        c.dustDiameterSigma = d.diameterSigma;
        c.dustMask = loadMask(d.mask, k);
    }
    for (const GreaseSpec& g : s.grease) {
        const int k = surfaceIndex(g.surface, g.line, "grease");
        SurfaceContamination& c = options.contamination[k];
        c.greaseCoverage = g.coverage, c.greaseRoughness = g.roughness;
        c.greaseMask = loadMask(g.mask, k);
    }
    options.media.clear();
    for (const BulkSpec& b : s.bulk) {
        if (b.element >= n || lens.mediumBefore(b.element).isAir())
            throw InputError(scene.sourceFile, b.line,
                             "bulk: element " + std::to_string(b.element) +
                                 " must be the number of the first surface of a glass element (glass after it)");
        for (const BulkMedium& other : options.media)
            if (other.cell == b.element)
                throw InputError(scene.sourceFile, b.line, "bulk: element " + std::to_string(b.element) + " is given twice");
        BulkMedium medium;
        medium.cell = b.element;  // cell g lies between surfaces g − 1 and g (0-based)
        medium.scatteringPerMm = b.scatteringPerMm, medium.absorptionPerMm = b.absorptionPerMm;
        medium.g = b.g, medium.rayleigh = b.rayleigh;
        if (!b.grid.empty()) medium.grid = std::make_shared<VolumeGrid>(VolumeGrid::load(b.grid, b.gridName));
        options.media.push_back(std::move(medium));
    }
}

}  // namespace flare
