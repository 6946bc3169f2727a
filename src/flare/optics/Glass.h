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

// λ in µm throughout. The first two are the built-in table's layouts; the rest are the dispersion
// formulas of Zemax glass catalogues (.agf, AgfCatalog.h) by their formula number, with the
// coefficients in the catalogue's order.
enum class GlassFormula {
    Sellmeier3,  // n² − 1 = Σ Bᵢλ²/(λ² − Cᵢ), coefficients {B1,B2,B3,C1,C2,C3}
    Polynomial,  // n² = A0 + A1λ² + A2λ⁻² + A3λ⁻⁴ + A4λ⁻⁶ + A5λ⁻⁸, coefficients {A0..A5}
    AgfSchott,       // 1: n² = a0 + a1λ² + a2λ⁻² + a3λ⁻⁴ + a4λ⁻⁶ + a5λ⁻⁸
    AgfSellmeier1,   // 2: n² − 1 = Σ(i<3) Kᵢλ²/(λ² − Lᵢ), {K1, L1, K2, L2, K3, L3}
    AgfHerzberger,   // 3: n = A + B·L + C·L² + Dλ² + Eλ⁴ + Fλ⁶, L = 1/(λ² − 0.028)
    AgfSellmeier2,   // 4: n² − 1 = A + B1λ²/(λ² − λ1²) + B2/(λ² − λ2²), {A, B1, λ1, B2, λ2}
    AgfConrady,      // 5: n = n0 + A/λ + B/λ^3.5
    AgfSellmeier3,   // 6: n² − 1 = Σ(i<4) Kᵢλ²/(λ² − Lᵢ)
    AgfHandbook1,    // 7: n² = A + B/(λ² − C) − Dλ²
    AgfHandbook2,    // 8: n² = A + Bλ²/(λ² − C) − Dλ²
    AgfSellmeier4,   // 9: n² = A + Bλ²/(λ² − C) + Dλ²/(λ² − E)
    AgfExtended1,    // 10: n² = a0 + a1λ² + a2λ⁻² + … + a7λ⁻¹²
    AgfSellmeier5,   // 11: n² − 1 = Σ(i<5) Kᵢλ²/(λ² − Lᵢ)
    AgfExtended2,    // 12: n² = a0 + a1λ² + a2λ⁻² + a3λ⁻⁴ + a4λ⁻⁶ + a5λ⁻⁸ + a6λ⁴ + a7λ⁶
    AgfExtended3,    // 13: n² = a0 + a1λ² + a2λ⁴ + a3λ⁻² + a4λ⁻⁴ + a5λ⁻⁶ + a6λ⁻⁸ + a7λ⁻¹⁰ + a8λ⁻¹²
};

inline constexpr int kGlassCoefficients = 10;  // the most any formula takes (Sellmeier 5)

struct CatalogGlass {
    const char* name;
    const char* maker;  // the maker, or for a glass from an .agf file its catalogue
    GlassFormula formula;
    double coefficients[kGlassCoefficients];
    double nd;  // as printed in the catalogue
    double vd;  // as printed in the catalogue
    double minWavelengthNm = 0.0, maxWavelengthNm = 0.0;  // where the formula holds (0, 0: not stated)
};

// Refractive index of a catalogue glass from its dispersion formula.
double catalogIndex(const CatalogGlass& glass, double wavelengthNm);
// The same for a formula and its coefficients (kGlassCoefficients of them).
double dispersionIndex(GlassFormula formula, const double* coefficients, double wavelengthNm);

// Whether the glass can serve in the visible: its stated range (if any) spans F to C and its formula
// gives a real index of at least 1 from 360 to 830 nm (the range the engine samples). Infrared
// glasses do not.
bool coversVisible(const CatalogGlass& glass);
// "its catalogue range is 2.5 to 14 µm" (or, with no stated range, that its formula fails there).
std::string validRangeText(const CatalogGlass& glass);

// The built-in catalogue (Schott, Ohara, Hoya), in file order.
std::span<const CatalogGlass> glassCatalog();

// Case-insensitive lookup by name: the built-in catalogue, then the shipped vendor catalogues
// (AgfCatalog.h, shippedGlassCatalogs), in their order. `CATALOG:NAME` (e.g. `HOYA:FCD1`) looks in
// one shipped catalogue only. nullptr if unknown.
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
