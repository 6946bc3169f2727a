#include "flare/optics/LensPrescription.h"

namespace flare {

int LensPrescription::stopRow() const {
    for (size_t i = 0; i < rows.size(); ++i)
        if (rows[i].isStop) return static_cast<int>(i);
    return -1;
}

const VariableGap* LensPrescription::findGap(const std::string& gapName) const {
    for (const VariableGap& g : gaps)
        if (g.name == gapName) return &g;
    return nullptr;
}

const VariableAperture* LensPrescription::findAperture(const std::string& apertureName) const {
    for (const VariableAperture& a : apertures)
        if (a.name == apertureName) return &a;
    return nullptr;
}

std::optional<Coating> LensPrescription::findCoating(const std::string& coatingName) const {
    for (const Coating& c : coatings)
        if (c.name == coatingName) return c;
    if (coatingName == "none") return Coating{"none", {}, {}};
    if (coatingName == "mgf2") return Coating::magnesiumFluoride();
    return std::nullopt;
}

}  // namespace flare
