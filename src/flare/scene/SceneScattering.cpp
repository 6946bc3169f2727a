#include "flare/scene/SceneScattering.h"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>

#include "flare/core/Error.h"
#include "flare/optics/LensFile.h"
#include "flare/photons/CoverageMask.h"
#include "flare/photons/VolumeGrid.h"

namespace flare {

namespace scenefile {

namespace {

FinishSpec parseFinish(const Checker& c, const Node& node, const std::string& path) {
    FinishSpec f;
    c.object(node, path, {"diffuse", "glossy"});
    if (const Member* m = Checker::find(node, "diffuse")) f.diffuse = c.numberIn(m->value, child(path, "diffuse"), 0.0, 1.0, "");
    if (const Member* m = Checker::find(node, "glossy")) f.glossy = c.numberIn(m->value, child(path, "glossy"), 0.0, 1.0, "");
    if (f.diffuse + f.glossy > 1.0)
        c.fail(node.line, path, "diffuse + glossy must not exceed 1 (energy), got " + formatNumber(f.diffuse + f.glossy));
    return f;
}

// A data file named in the scene (at `line`, key `path`), relative to the scene's folder (kept as
// given if that does not exist, so that the error names what the user wrote). A name the system
// cannot look up (too long, through a file, no permission) is an error at the scene's line.
std::string resolveDataFile(const Checker& c, int line, const std::string& path, const std::string& file,
                            const std::string& baseDir) {
    const std::filesystem::path resolved = std::filesystem::path(baseDir) / file;
    std::error_code ec;
    const bool exists = std::filesystem::exists(resolved, ec);
    if (ec && ec != std::errc::no_such_file_or_directory)
        c.fail(line, path, "cannot use the file '" + resolved.string() + "': " + ec.message());
    return exists || baseDir.empty() ? resolved.string() : file;
}

// The optional "mask", "mask_size_mm" (a width, or [width, height]) and "mask_centre_mm" keys of
// a dust or grease entry.
MaskSpec parseMask(const Checker& c, const Node& item, const std::string& path, const std::string& baseDir) {
    MaskSpec mask;
    const Member* file = Checker::find(item, "mask");
    const Member* size = Checker::find(item, "mask_size_mm");
    const Member* centre = Checker::find(item, "mask_centre_mm");
    if (!file) {
        if (size || centre)
            c.fail((size ? size : centre)->keyLine, child(path, size ? "mask_size_mm" : "mask_centre_mm"),
                   "is only allowed with a 'mask' image");
        return mask;
    }
    mask.keyPath = child(path, "mask");
    mask.line = file->value.line;
    const std::string& name = c.string(file->value, mask.keyPath);
    if (name.empty()) c.fail(mask.line, mask.keyPath, "must name a PNG or EXR image file");
    mask.file = resolveDataFile(c, mask.line, mask.keyPath, name, baseDir);
    if (size) {
        const std::string sizePath = child(path, "mask_size_mm");
        if (size->value.kind == Node::Kind::Array) {
            const auto& wh = c.numbers(size->value, sizePath, 2, "a width, or [width, height], in mm");
            mask.widthMm = c.numberIn(wh[0], index(sizePath, 0), 0.0, 1e4, "mm", true);
            mask.heightMm = c.numberIn(wh[1], index(sizePath, 1), 0.0, 1e4, "mm", true);
        } else {
            mask.widthMm = c.numberIn(size->value, sizePath, 0.0, 1e4, "mm", true);
        }
    }
    if (centre) {
        const std::string centrePath = child(path, "mask_centre_mm");
        const auto& xy = c.numbers(centre->value, centrePath, 2, "[x, y] in mm");
        mask.centreMm = {c.numberIn(xy[0], index(centrePath, 0), -1e4, 1e4, "mm"),
                         c.numberIn(xy[1], index(centrePath, 1), -1e4, 1e4, "mm")};
    }
    return mask;
}

}  // namespace

void parseScattering(const Checker& c, const Node& node, const std::string& baseDir, ScatteringSettings& s) {
    c.object(node, "scattering", {"housing", "edges", "iris", "gloss_exponent", "dust", "grease", "bulk"});
    if (const Member* m = Checker::find(node, "housing")) s.housing = parseFinish(c, m->value, "scattering.housing");
    if (const Member* m = Checker::find(node, "edges")) s.edges = parseFinish(c, m->value, "scattering.edges");
    if (const Member* m = Checker::find(node, "iris")) s.iris = parseFinish(c, m->value, "scattering.iris");
    if (const Member* m = Checker::find(node, "gloss_exponent"))
        s.glossExponent = c.numberIn(m->value, "scattering.gloss_exponent", 0.0, 1e5, "");
    auto items = [&](const char* key) -> const std::vector<Node>* {
        const Member* m = Checker::find(node, key);
        if (!m) return nullptr;
        if (m->value.kind != Node::Kind::Array)
            c.fail(m->value.line, child("scattering", key), "must be an array of objects, got " + describe(m->value));
        return &m->value.items;
    };
    auto surfaceNumber = [&](const Node& item, const std::string& path, const char* key) {
        return static_cast<int>(c.integerIn(c.require(item, path, key).value, child(path, key), 1, kMaxSurfaces));
    };
    if (const auto* list = items("dust"))
        for (std::size_t i = 0; i < list->size(); ++i) {
            const Node& item = (*list)[i];
            const std::string path = index("scattering.dust", i);
            c.object(item, path, {"surface", "coverage", "albedo", "diameter_um", "diameter_sigma", "mask", "mask_size_mm",
                                  "mask_centre_mm"});
            DustSpec d;
            d.line = item.line;
            d.surface = surfaceNumber(item, path, "surface");
            d.coverage = c.numberIn(c.require(item, path, "coverage").value, child(path, "coverage"), 0.0, 1.0, "");
            if (const Member* m = Checker::find(item, "albedo")) d.albedo = c.numberIn(m->value, child(path, "albedo"), 0.0, 1.0, "");
            if (const Member* m = Checker::find(item, "diameter_um"))
                d.diameterUm = c.numberIn(m->value, child(path, "diameter_um"), 0.0, 1e4, "um", true);
            if (const Member* m = Checker::find(item, "diameter_sigma"))
                d.diameterSigma = c.numberIn(m->value, child(path, "diameter_sigma"), 0.0, 3.0, "");
            d.mask = parseMask(c, item, path, baseDir);
            s.dust.push_back(d);
        }
    if (const auto* list = items("grease"))
        for (std::size_t i = 0; i < list->size(); ++i) {
            const Node& item = (*list)[i];
            const std::string path = index("scattering.grease", i);
            c.object(item, path, {"surface", "coverage", "roughness", "mask", "mask_size_mm", "mask_centre_mm"});
            GreaseSpec g;
            g.line = item.line;
            g.surface = surfaceNumber(item, path, "surface");
            g.coverage = c.numberIn(c.require(item, path, "coverage").value, child(path, "coverage"), 0.0, 1.0, "");
            if (const Member* m = Checker::find(item, "roughness"))
                g.roughness = c.numberIn(m->value, child(path, "roughness"), 0.0, 1.0, "", true);
            g.mask = parseMask(c, item, path, baseDir);
            s.grease.push_back(g);
        }
    if (const auto* list = items("bulk"))
        for (std::size_t i = 0; i < list->size(); ++i) {
            const Node& item = (*list)[i];
            const std::string path = index("scattering.bulk", i);
            c.object(item, path, {"element", "scattering_per_mm", "absorption_per_mm", "g", "rayleigh", "grid", "grid_name"});
            BulkSpec b;
            b.line = item.line;
            b.element = surfaceNumber(item, path, "element");
            b.scatteringPerMm = c.numberIn(c.require(item, path, "scattering_per_mm").value, child(path, "scattering_per_mm"),
                                           0.0, 100.0, "per mm");
            if (const Member* m = Checker::find(item, "absorption_per_mm"))
                b.absorptionPerMm = c.numberIn(m->value, child(path, "absorption_per_mm"), 0.0, 100.0, "per mm");
            if (const Member* m = Checker::find(item, "g")) b.g = c.numberIn(m->value, child(path, "g"), -0.99, 0.99, "");
            if (const Member* m = Checker::find(item, "rayleigh")) b.rayleigh = c.boolean(m->value, child(path, "rayleigh"));
            if (const Member* m = Checker::find(item, "grid")) {
                b.grid = resolveDataFile(c, m->value.line, child(path, "grid"), c.string(m->value, child(path, "grid")), baseDir);
            }
            if (const Member* m = Checker::find(item, "grid_name")) b.gridName = c.string(m->value, child(path, "grid_name"));
            s.bulk.push_back(b);
        }
}

}  // namespace scenefile

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
