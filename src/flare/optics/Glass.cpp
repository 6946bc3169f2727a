#include "flare/optics/Glass.h"

#include <algorithm>
#include <cassert>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>

#include "flare/core/Spectrum.h"
#include "flare/optics/AgfCatalog.h"

namespace flare {

namespace {

const CatalogGlass kCatalog[] = {
#include "flare/optics/GlassCatalogData.inc"
};

bool equalsIgnoreCase(std::string_view a, std::string_view b) {
    if (a.size() != b.size()) return false;
    for (size_t i = 0; i < a.size(); ++i) {
        if (std::tolower(static_cast<unsigned char>(a[i])) !=
            std::tolower(static_cast<unsigned char>(b[i])))
            return false;
    }
    return true;
}

}  // namespace

double dispersionIndex(GlassFormula formula, const double* k, double wavelengthNm) {
    const double l = wavelengthNm * 1e-3;  // µm
    const double l2 = l * l, inv2 = 1.0 / l2;
    // Σ Kᵢλ²/(λ² − Lᵢ) over `terms` interleaved (K, L) pairs.
    auto sellmeier = [&](int terms) {
        double sum = 0.0;
        for (int i = 0; i < terms; ++i) sum += k[2 * i] * l2 / (l2 - k[2 * i + 1]);
        return sum;
    };
    // a0 + a1λ² + a2λ⁻² + a3λ⁻⁴ + …, the negative powers from k[2] on, `negative` of them.
    auto laurent = [&](int negative) {
        double tail = 0.0;
        for (int i = negative - 1; i >= 0; --i) tail = inv2 * (k[2 + i] + tail);
        return k[0] + k[1] * l2 + tail;
    };
    double n2 = 1.0;
    switch (formula) {
        case GlassFormula::Sellmeier3:
            n2 = 1.0 + k[0] * l2 / (l2 - k[3]) + k[1] * l2 / (l2 - k[4]) + k[2] * l2 / (l2 - k[5]);
            break;
        case GlassFormula::Polynomial:
        case GlassFormula::AgfSchott: n2 = laurent(4); break;
        case GlassFormula::AgfSellmeier1: n2 = 1.0 + sellmeier(3); break;
        case GlassFormula::AgfHerzberger: {
            const double L = 1.0 / (l2 - 0.028);
            return k[0] + k[1] * L + k[2] * L * L + l2 * (k[3] + l2 * (k[4] + l2 * k[5]));
        }
        case GlassFormula::AgfSellmeier2:
            n2 = 1.0 + k[0] + k[1] * l2 / (l2 - k[2] * k[2]) + k[3] / (l2 - k[4] * k[4]);
            break;
        case GlassFormula::AgfConrady: return k[0] + k[1] / l + k[2] / std::pow(l, 3.5);
        case GlassFormula::AgfSellmeier3: n2 = 1.0 + sellmeier(4); break;
        case GlassFormula::AgfHandbook1: n2 = k[0] + k[1] / (l2 - k[2]) - k[3] * l2; break;
        case GlassFormula::AgfHandbook2: n2 = k[0] + k[1] * l2 / (l2 - k[2]) - k[3] * l2; break;
        case GlassFormula::AgfSellmeier4: n2 = k[0] + k[1] * l2 / (l2 - k[2]) + k[3] * l2 / (l2 - k[4]); break;
        case GlassFormula::AgfExtended1: n2 = laurent(6); break;
        case GlassFormula::AgfSellmeier5: n2 = 1.0 + sellmeier(5); break;
        case GlassFormula::AgfExtended2: n2 = laurent(4) + l2 * l2 * (k[6] + k[7] * l2); break;
        case GlassFormula::AgfExtended3: {
            double tail = 0.0;
            for (int i = 5; i >= 0; --i) tail = inv2 * (k[3 + i] + tail);
            n2 = k[0] + l2 * (k[1] + l2 * k[2]) + tail;
            break;
        }
    }
    return std::sqrt(n2);
}

double catalogIndex(const CatalogGlass& glass, double wavelengthNm) {
    return dispersionIndex(glass.formula, glass.coefficients, wavelengthNm);
}

bool coversVisible(const CatalogGlass& glass) {
    if (glass.maxWavelengthNm > 0.0 && (glass.minWavelengthNm > kLineFNm || glass.maxWavelengthNm < kLineCNm))
        return false;
    for (double nm = kCieMinNm; nm <= kCieMaxNm; nm += 10.0)
        if (!(catalogIndex(glass, nm) >= 1.0)) return false;
    return true;
}

std::string validRangeText(const CatalogGlass& glass) {
    if (!(glass.maxWavelengthNm > 0.0)) return "its formula gives no real index across 360 to 830 nm";
    char buffer[96];
    std::snprintf(buffer, sizeof buffer, "its catalogue range is %g to %g µm", glass.minWavelengthNm * 1e-3,
                  glass.maxWavelengthNm * 1e-3);
    return buffer;
}

std::span<const CatalogGlass> glassCatalog() { return kCatalog; }

const CatalogGlass* findCatalogGlass(std::string_view name) {
    const size_t colon = name.find(':');
    // Private catalogues first: the user gave them for this (useGlassCatalog).
    for (const AgfCatalog* catalog : privateGlassCatalogs()) {
        if (colon != std::string_view::npos && !equalsIgnoreCase(catalog->name(), name.substr(0, colon))) continue;
        if (const CatalogGlass* g = catalog->find(colon == std::string_view::npos ? name : name.substr(colon + 1)))
            return g;
    }
    if (colon == std::string_view::npos)
        for (const CatalogGlass& g : kCatalog)
            if (equalsIgnoreCase(g.name, name)) return &g;
    for (const AgfCatalog& catalog : shippedGlassCatalogs()) {
        if (colon != std::string_view::npos && !equalsIgnoreCase(catalog.name(), name.substr(0, colon))) continue;
        if (const CatalogGlass* g = catalog.find(colon == std::string_view::npos ? name : name.substr(colon + 1)))
            return g;
    }
    return nullptr;
}

const CatalogGlass& nearestCatalogGlass(double nd, double vd) {
    const CatalogGlass* best = &kCatalog[0];
    double bestDistance = std::numeric_limits<double>::infinity();
    for (const CatalogGlass& g : kCatalog) {
        const double dn = (g.nd - nd) / 0.01;
        const double dv = g.vd - vd;
        const double distance = dn * dn + dv * dv;
        if (distance < bestDistance) {
            bestDistance = distance;
            best = &g;
        }
    }
    return *best;
}

Medium Medium::air() { return Medium{}; }

Medium Medium::constant(double index) {
    Medium m;
    m.kind_ = Kind::Constant;
    m.constantIndex_ = index;
    m.nd_ = index;
    return m;
}

Medium Medium::catalog(const CatalogGlass& glass) {
    Medium m;
    m.kind_ = Kind::Catalog;
    m.glass_ = &glass;
    m.nd_ = catalogIndex(glass, kLineDNm);
    const double dispersion = catalogIndex(glass, kLineFNm) - catalogIndex(glass, kLineCNm);
    m.vd_ = (m.nd_ - 1.0) / dispersion;
    return m;
}

Medium Medium::abbe(double nd, double vd) {
    assert(nd > 1.0 && vd > 0.0);
    const CatalogGlass& base = nearestCatalogGlass(nd, vd);
    Medium m;
    m.kind_ = Kind::AbbeMatched;
    m.glass_ = &base;
    m.nd_ = nd;
    m.vd_ = vd;
    const double baseDispersion = catalogIndex(base, kLineFNm) - catalogIndex(base, kLineCNm);
    m.dispersionScale_ = ((nd - 1.0) / vd) / baseDispersion;
    return m;
}

Medium Medium::cauchy(double nd, double vd) {
    assert(nd > 1.0 && vd > 0.0);
    Medium m;
    m.kind_ = Kind::Cauchy;
    m.nd_ = nd;
    m.vd_ = vd;
    m.cauchyBNm2_ = ((nd - 1.0) / vd) / (1.0 / (kLineFNm * kLineFNm) - 1.0 / (kLineCNm * kLineCNm));
    m.cauchyA_ = nd - m.cauchyBNm2_ / (kLineDNm * kLineDNm);
    return m;
}

double Medium::indexAt(double wavelengthNm) const {
    switch (kind_) {
        case Kind::Air: return 1.0;
        case Kind::Constant: return constantIndex_;
        case Kind::Catalog: return catalogIndex(*glass_, wavelengthNm);
        case Kind::AbbeMatched: {
            const double baseNd = catalogIndex(*glass_, kLineDNm);
            return nd_ + dispersionScale_ * (catalogIndex(*glass_, wavelengthNm) - baseNd);
        }
        case Kind::Cauchy: return cauchyA_ + cauchyBNm2_ / (wavelengthNm * wavelengthNm);
    }
    return 1.0;
}

double Medium::nd() const { return nd_; }

double Medium::vd() const {
    if (kind_ == Kind::Air || kind_ == Kind::Constant) return std::numeric_limits<double>::infinity();
    return vd_;
}

std::string Medium::describe() const {
    char buffer[160];
    switch (kind_) {
        case Kind::Air: return "air";
        case Kind::Constant:
            std::snprintf(buffer, sizeof buffer, "n=%.5f (constant)", constantIndex_);
            return buffer;
        case Kind::Catalog:
            std::snprintf(buffer, sizeof buffer, "%s (%s)", glass_->name, glass_->maker);
            return buffer;
        case Kind::AbbeMatched:
            std::snprintf(buffer, sizeof buffer, "%.5f/%.2f (dispersion of %s, %s)", nd_, vd_,
                          glass_->name, glass_->maker);
            return buffer;
        case Kind::Cauchy:
            std::snprintf(buffer, sizeof buffer, "%.5f/%.2f (Cauchy)", nd_, vd_);
            return buffer;
    }
    return "?";
}

}  // namespace flare
