// How much the ghost table of a library lens depends on the dispersion model its glasses get. The
// collections give each glass as (nd, Vd) only; the library gives it the dispersion shape of the
// nearest catalogue glass scaled to those two numbers (Medium::abbe). The other reasonable model
// is Cauchy's two terms through the same nd and Vd (Medium::cauchy). For ten library lenses, evenly
// spaced over the library sorted by focal length, and a light at half the field's half-diagonal,
// the ghost analysis runs at 450, 550 and 650 nm with both models; for the ghosts holding at least
// 1 % of the ghost power, the table gives the median and largest relative change of a ghost's
// power, the change of the total, and the largest relative change of a ghost's size on the sensor
// (the paraxial marginal ray's height there; a focus distance is no measure: nearly afocal ghosts'
// foci run off to infinity on the slightest change).
//
//   flare_dispersion_models [--lenses N]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

#include <CLI/CLI.hpp>
#include <glm/geometric.hpp>

#include "flare/ghosts/GhostAnalysis.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/LensSystem.h"
#include "flare/optics/Paraxial.h"

using namespace flare;

namespace {

struct Change {
    double medianPower = 0.0, largestPower = 0.0, total = 0.0, largestSize = 0.0;
    int ghosts = 0;
};

Change compare(const GhostReport& a, const GhostReport& b) {
    std::map<std::vector<int>, const GhostEstimate*> inB;
    for (const GhostEstimate& g : b.ghosts) inB[g.path.reflections] = &g;
    double totalA = 0.0, totalB = 0.0;
    for (const GhostEstimate& g : a.ghosts) totalA += g.powerFraction;
    for (const GhostEstimate& g : b.ghosts) totalB += g.powerFraction;
    Change c;
    c.total = totalA > 0.0 ? totalB / totalA - 1.0 : 0.0;
    std::vector<double> changes;
    for (const GhostEstimate& g : a.ghosts) {
        if (g.powerFraction < 0.01 * totalA) continue;
        const auto it = inB.find(g.path.reflections);
        const double other = it == inB.end() ? 0.0 : it->second->powerFraction;
        changes.push_back(std::abs(other / g.powerFraction - 1.0));
        if (it == inB.end() || g.paraxial.marginalHeightsMm.empty() || it->second->paraxial.marginalHeightsMm.empty())
            continue;
        const double ha = std::abs(g.paraxial.marginalHeightsMm.back());
        const double hb = std::abs(it->second->paraxial.marginalHeightsMm.back());
        if (ha > 0.0) c.largestSize = std::max(c.largestSize, std::abs(hb / ha - 1.0));
    }
    c.ghosts = static_cast<int>(changes.size());
    if (!changes.empty()) {
        std::sort(changes.begin(), changes.end());
        c.medianPower = changes[changes.size() / 2];
        c.largestPower = changes.back();
    }
    return c;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app("ghost tables of library lenses under two dispersion models for their (nd, Vd) glasses");
    int count = 10;
    app.add_option("--lenses", count, "how many library lenses (evenly spaced by focal length)");
    CLI11_PARSE(app, argc, argv);

    std::vector<LibraryLens> lenses = LensLibrary::shared().lenses();
    std::stable_sort(lenses.begin(), lenses.end(),
                     [](const LibraryLens& a, const LibraryLens& b) { return a.focalLengthMm < b.focalLengthMm; });
    if (lenses.empty()) {
        std::fprintf(stderr, "no library lenses found\n");
        return 1;
    }
    std::printf("| lens | f (mm) | glasses | λ (nm) | ghosts ≥ 1 %% | median |ΔP/P| | largest |ΔP/P| | Δ total | largest |Δsize/size| |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|\n");
    for (int k = 0; k < count; ++k) {
        const LibraryLens& entry = lenses[(static_cast<size_t>(k) * (lenses.size() - 1)) / std::max(1, count - 1)];
        const LensPrescription abbe = loadLens(entry.path);
        LensPrescription cauchy = abbe;
        int glasses = 0;
        for (PrescriptionRow& row : cauchy.rows)
            if (row.mediumAfter.kind() == Medium::Kind::AbbeMatched) {
                row.mediumAfter = Medium::cauchy(row.mediumAfter.nd(), row.mediumAfter.vd());
                ++glasses;
            }
        const LensSystem a = LensSystem::build(abbe), b = LensSystem::build(cauchy);
        // Half the field's half-diagonal, along the diagonal.
        const double half = std::atan(a.sensorHalfDiagonalMm() / std::max(std::abs(analyseParaxial(a, 550.0).eflMm), 1e-3));
        const double w = a.sensor().widthMm, h = a.sensor().heightMm;
        const glm::dvec3 direction =
            glm::normalize(glm::dvec3(std::tan(0.5 * half) * w / std::hypot(w, h), std::tan(0.5 * half) * h / std::hypot(w, h), 1.0));
        for (double nm : {450.0, 550.0, 650.0}) {
            GhostAnalysisOptions options;
            options.wavelengthNm = nm;
            const Change c = compare(analyseGhosts(a, direction, options), analyseGhosts(b, direction, options));
            std::printf("| %s | %.1f | %d | %.0f | %d | %.2g | %.2g | %+.2g | %.3g |\n", entry.id.c_str(),
                        entry.focalLengthMm, glasses, nm, c.ghosts, c.medianPower, c.largestPower, c.total,
                        c.largestSize);
            std::fflush(stdout);
        }
    }
    return 0;
}
