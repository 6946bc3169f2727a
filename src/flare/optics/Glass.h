// Optical media: air, catalogue glasses (Sellmeier or polynomial dispersion formulas), glasses
// given only by (nd, Vd) and constant-index media. Every medium answers "index at wavelength".
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace flare {

// Fraunhofer lines used to define nd and Vd (nm).
inline constexpr double kLineDNm = 587.5618;
inline constexpr double kLineFNm = 486.1327;
inline constexpr double kLineCNm = 656.2725;

enum class GlassFormula {
    Sellmeier3,  // n² − 1 = Σ Bᵢλ²/(λ² − Cᵢ), coefficients {B1,B2,B3,C1,C2,C3}, λ in µm
    Polynomial,  // n² = A0 + A1λ² + A2λ⁻² + A3λ⁻⁴ + A4λ⁻⁶ + A5λ⁻⁸, coefficients {A0..A5}
};

struct CatalogGlass {
    const char* name;
    const char* maker;
    GlassFormula formula;
    double coefficients[6];
    double nd;  // as printed in the catalogue
    double vd;  // as printed in the catalogue
};

// Refractive index of a catalogue glass from its dispersion formula.
double catalogIndex(const CatalogGlass& glass, double wavelengthNm);

// The built-in catalogue (Schott, Ohara, Hoya), in file order.
std::span<const CatalogGlass> glassCatalog();

// Case-insensitive lookup by name; nullptr if unknown.
const CatalogGlass* findCatalogGlass(std::string_view name);

// The catalogue glass closest to (nd, Vd) on the glass map, with Δnd weighted so that 0.01 in nd
// counts like 1 in Vd (the usual scale of the nd–Vd diagram).
const CatalogGlass& nearestCatalogGlass(double nd, double vd);

class Medium {
public:
    enum class Kind { Air, Constant, Catalog, AbbeMatched, Cauchy };

    static Medium air();
    static Medium constant(double index);
    static Medium catalog(const CatalogGlass& glass);
    // A glass known by (nd, Vd) only: the dispersion shape of the nearest catalogue glass, scaled
    // so that n(d) = nd and (nd − 1)/(nF − nC) = Vd hold exactly.
    static Medium abbe(double nd, double vd);
    // The same (nd, Vd) with Cauchy's two-term dispersion n(λ) = A + B/λ² through the d line and
    // with nF − nC = (nd − 1)/Vd: the simplest model these two numbers define, the other
    // reasonable choice against which the library's lenses were compared (docs/lens-library.md).
    static Medium cauchy(double nd, double vd);

    double indexAt(double wavelengthNm) const;

    Kind kind() const { return kind_; }
    bool isAir() const { return kind_ == Kind::Air; }
    // The catalogue glass supplying the dispersion (Catalog and AbbeMatched), else nullptr.
    const CatalogGlass* baseGlass() const { return glass_; }
    // nd and Vd of this medium (Vd is infinite for non-dispersive media).
    double nd() const;
    double vd() const;
    // One line for reports: "air", "n=1.67 (constant)", "N-BK7 (Schott)",
    // "1.6700/47.20 (dispersion of N-BAF10, Schott)".
    std::string describe() const;

private:
    Kind kind_ = Kind::Air;
    double constantIndex_ = 1.0;
    const CatalogGlass* glass_ = nullptr;
    double nd_ = 1.0;
    double vd_ = 0.0;
    double dispersionScale_ = 1.0;  // AbbeMatched: n(λ) = nd + scale·(n_base(λ) − nd_base)
    double cauchyA_ = 1.0, cauchyBNm2_ = 0.0;  // Cauchy: n(λ) = A + B/λ², λ in nm
};

}  // namespace flare
