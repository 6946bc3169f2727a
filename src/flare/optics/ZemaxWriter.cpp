// The Zemax writer (ZemaxFile.h, writeZemax): a prescription as .zmx text, with what a .zmx cannot
// say in flare's notes, which the reader (ZemaxFile.cpp) applies.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <string>
#include <vector>

#include "flare/core/TextEncoding.h"
#include "flare/optics/Glass.h"
#include "flare/optics/LensSystem.h"
#include "flare/optics/ZemaxFile.h"

namespace flare {

namespace {

// The primary wavelength the writer gives: where Zemax's AR coating is a quarter wave, flare's
// mgf2 (a quarter wave of MgF2 at 550 nm).
constexpr double kMgF2DesignNm = 550.0;

// The catalogue a .zmx file names for a glass: an .agf catalogue's own name, the maker of a
// built-in glass in capitals (its catalogue's file name).
std::string catalogName(const CatalogGlass& glass) { return asciiUpper(glass.maker); }

void line(std::string& out, const std::string& text) { out += text + "\r\n"; }

}  // namespace

std::string writeZemax(const LensPrescription& p) {
    // Every zoom position resolved once: its thicknesses (an `auto` one is the focus solve's).
    std::vector<LensSystem> positions;
    if (p.zoomPositions.empty()) positions.push_back(LensSystem::build(p));
    for (const ZoomPosition& z : p.zoomPositions) positions.push_back(LensSystem::build(p, LensState{z.name, {}, {}}));
    auto thicknessAt = [&](size_t position, size_t row) {
        const ThicknessSpec& t = p.rows[row].thickness;
        switch (t.kind) {
            case ThicknessSpec::Kind::Value: return t.valueMm;
            case ThicknessSpec::Kind::Gap: return p.findGap(t.gapName)->valuesMm[position];
            case ThicknessSpec::Kind::Auto: break;
        }
        const LensSystem& lens = positions[position];
        return lens.sensorZMm() - lens.surface(lens.surfaceCount() - 1).vertexZMm;
    };

    std::string out;
    line(out, "MODE SEQ");
    line(out, "NAME " + p.name);
    line(out, "UNIT MM X W X CM MR CPMM");
    if (p.fNumber) line(out, "FNUM " + shortestNumberText(*p.fNumber) + " 0");
    std::vector<std::string> catalogs;
    for (const PrescriptionRow& row : p.rows)
        if (const CatalogGlass* glass = row.mediumAfter.kind() == Medium::Kind::Catalog ? row.mediumAfter.baseGlass() : nullptr)
            if (std::find(catalogs.begin(), catalogs.end(), catalogName(*glass)) == catalogs.end())
                catalogs.push_back(catalogName(*glass));
    if (!catalogs.empty()) {
        std::string gcat = "GCAT";
        for (const std::string& c : catalogs) gcat += " " + c;
        line(out, gcat);
    }
    // The primary wavelength is where Zemax's AR coating is a quarter wave: flare's mgf2 at 550 nm.
    line(out, "WAVM 1 " + shortestNumberText(kLineFNm / 1000.0) + " 1");
    line(out, "WAVM 2 " + shortestNumberText(kMgF2DesignNm / 1000.0) + " 1");
    line(out, "WAVM 3 " + shortestNumberText(kLineCNm / 1000.0) + " 1");
    line(out, "PWAV 2");
    // What a .zmx file cannot say, in notes Zemax keeps and ignores and flare reads back: the iris,
    // the zoom positions' names and published focal lengths, the coatings' layers.
    if (p.iris.blades != 0 || p.iris.rotationDeg != 0.0 || p.iris.curvature != 0.0)
        line(out, "NOTE 0 flare: iris blades=" + std::to_string(p.iris.blades) + " rotation_deg=" +
                      shortestNumberText(p.iris.rotationDeg) + " curvature=" + shortestNumberText(p.iris.curvature));
    if (!p.zoomPositions.empty()) {
        std::string zoom = "NOTE 0 flare: zoom";
        for (const ZoomPosition& z : p.zoomPositions) zoom += " " + z.name + "=" + shortestNumberText(z.focalLengthMm);
        line(out, zoom);
    }
    for (const Coating& c : p.coatings) {
        if (!c.changesInterface()) continue;
        std::string coating = "NOTE 0 flare: coating " + c.name;
        if (c.ideal) {
            coating += " ideal";
            for (size_t k = 0; k < c.ideal->wavelengthsNm.size(); ++k) {
                // Appended piece by piece (g++ 12 warns falsely of overlap for `" " + string&&`).
                coating += ' ';
                coating += shortestNumberText(c.ideal->wavelengthsNm[k]);
                coating += ':';
                coating += shortestNumberText(c.ideal->reflectances[k]);
            }
        } else {
            coating += " stack";
            for (const ThinFilmLayer& layer : c.layers) {
                coating += ' ';
                coating += shortestNumberText(layer.index);
                coating += ':';
                coating += shortestNumberText(layer.thicknessNm);
            }
        }
        line(out, coating);
    }

    line(out, "SURF 0");
    line(out, "  TYPE STANDARD");
    line(out, "  CURV 0");
    line(out, std::isinf(p.objectDistanceMm) ? "  DISZ INFINITY" : "  DISZ " + shortestNumberText(p.objectDistanceMm));
    std::vector<size_t> varying;  // rows whose thickness differs between positions
    for (size_t i = 0; i < p.rows.size(); ++i) {
        const PrescriptionRow& row = p.rows[i];
        line(out, "SURF " + std::to_string(i + 1));
        if (row.isStop) line(out, "  STOP");
        const bool aspheric = std::any_of(row.asphere.begin(), row.asphere.end(), [](double a) { return a != 0.0; });
        line(out, aspheric ? "  TYPE EVENASPH" : "  TYPE STANDARD");
        line(out, "  CURV " + shortestNumberText(row.radiusMm == 0.0 ? 0.0 : 1.0 / row.radiusMm));
        const Medium& before = i == 0 ? Medium::air() : p.rows[i - 1].mediumAfter;
        if (!row.isStop && before.isAir() != row.mediumAfter.isAir()) {
            const std::optional<Coating> coating = p.findCoating(row.coatingName.value_or(p.defaultCoating));
            if (coating && coating->changesInterface())
                line(out, "  COAT " + (coating->name == "mgf2" ? std::string("AR") : coating->name));
        }
        if (row.conic != 0.0) line(out, "  CONI " + shortestNumberText(row.conic));
        if (aspheric) {
            line(out, "  PARM 1 0");
            for (int t = 0; t < kAsphereTerms; ++t) line(out, "  PARM " + std::to_string(t + 2) + " " + shortestNumberText(row.asphere[t]));
        }
        const double thickness = thicknessAt(0, i);
        line(out, "  DISZ " + shortestNumberText(thickness));
        for (size_t c = 1; c < positions.size(); ++c)
            if (thicknessAt(c, i) != thickness && (varying.empty() || varying.back() != i)) varying.push_back(i);
        const Medium& m = row.mediumAfter;
        switch (m.kind()) {
            case Medium::Kind::Air: break;
            case Medium::Kind::Catalog:
                line(out, "  GLAS " + std::string(m.baseGlass()->name) + " 0 0 " + shortestNumberText(m.baseGlass()->nd) + " " +
                              shortestNumberText(m.baseGlass()->vd) + " 0 0 0 0 0 0");
                break;
            case Medium::Kind::Constant:
                line(out, "  GLAS ___BLANK 1 0 " + shortestNumberText(m.nd()) + " 0 0 0 0 0 0 0");
                break;
            // nd/Vd media are model glasses; a Cauchy medium's own dispersion is not a .zmx notion,
            // so it reads back as the nd/Vd medium of the same two numbers.
            case Medium::Kind::AbbeMatched:
            case Medium::Kind::Cauchy:
                line(out, "  GLAS ___BLANK 1 0 " + shortestNumberText(m.nd()) + " " + shortestNumberText(m.vd()) + " 0 0 0 0 0 0");
                break;
        }
        // A zoom's iris (an `aperture` line): the first position's opening here, every position's
        // as an SDIA operand below.
        const VariableAperture* aperture = row.semiApertureName.empty() ? nullptr : p.findAperture(row.semiApertureName);
        line(out, "  DIAM " + shortestNumberText(aperture ? aperture->valuesMm[0] : row.semiApertureMm));
        if (row.mechSemiDiameterMm) line(out, "  MEMA " + shortestNumberText(*row.mechSemiDiameterMm));
    }
    line(out, "SURF " + std::to_string(p.rows.size() + 1));
    line(out, "  TYPE STANDARD");
    line(out, "  CURV 0");
    line(out, "  DISZ 0");
    line(out, "  DIAM " + shortestNumberText(positions.front().sensorHalfDiagonalMm()));
    if (positions.size() > 1) {
        line(out, "MNUM " + std::to_string(positions.size()) + " 1");
        for (size_t i : varying)
            for (size_t c = 0; c < positions.size(); ++c)
                line(out, "THIC " + std::to_string(i + 1) + " " + std::to_string(c + 1) + " " +
                              shortestNumberText(thicknessAt(c, i)));
        for (size_t i = 0; i < p.rows.size(); ++i) {
            if (p.rows[i].semiApertureName.empty()) continue;
            const VariableAperture* aperture = p.findAperture(p.rows[i].semiApertureName);
            for (size_t c = 0; c < positions.size(); ++c)
                line(out, "SDIA " + std::to_string(i + 1) + " " + std::to_string(c + 1) + " " +
                              shortestNumberText(aperture->valuesMm[c]));
        }
    }
    return out;
}

}  // namespace flare
