#include "flare/optics/Glass.h"

#include <algorithm>
#include <cassert>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>

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

double catalogIndex(const CatalogGlass& glass, double wavelengthNm) {
    const double l = wavelengthNm * 1e-3;  // µm
    const double l2 = l * l;
    const double* k = glass.coefficients;
    double n2 = 1.0;
    switch (glass.formula) {
        case GlassFormula::Sellmeier3:
            n2 = 1.0 + k[0] * l2 / (l2 - k[3]) + k[1] * l2 / (l2 - k[4]) + k[2] * l2 / (l2 - k[5]);
            break;
        case GlassFormula::Polynomial: {
            const double inv2 = 1.0 / l2;
            n2 = k[0] + k[1] * l2 + inv2 * (k[2] + inv2 * (k[3] + inv2 * (k[4] + inv2 * k[5])));
            break;
        }
    }
    return std::sqrt(n2);
}

std::span<const CatalogGlass> glassCatalog() { return kCatalog; }

const CatalogGlass* findCatalogGlass(std::string_view name) {
    for (const CatalogGlass& g : kCatalog)
        if (equalsIgnoreCase(g.name, name)) return &g;
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
