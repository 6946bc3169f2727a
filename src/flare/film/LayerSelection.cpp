#include "flare/film/LayerSelection.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <stdexcept>

namespace flare {

namespace {

[[noreturn]] void badSelection(const std::string& text, const std::string& why) {
    throw std::invalid_argument("layers: \"" + text + "\" " + why +
                                " (all, top:N with N ≥ 1 ghosts, or share:F with 0 < F ≤ 1 of the ghosts' power)");
}

}  // namespace

LayerSelection LayerSelection::parse(const std::string& text) {
    LayerSelection selection;
    if (text == "all") return selection;
    const size_t colon = text.find(':');
    const std::string rule = text.substr(0, colon), value = colon == std::string::npos ? "" : text.substr(colon + 1);
    if (colon == std::string::npos || (rule != "top" && rule != "share")) badSelection(text, "is not a selection");
    if (value.empty() || std::isspace(static_cast<unsigned char>(value[0]))) badSelection(text, "has no number");
    char* end = nullptr;
    errno = 0;
    if (rule == "top") {
        const long long n = std::strtoll(value.c_str(), &end, 10);
        if (*end != '\0' || errno == ERANGE || n < 1 || n > INT_MAX) badSelection(text, "does not give a whole number of ghosts ≥ 1");
        selection.rule = Rule::Top;
        selection.top = static_cast<int>(n);
    } else {
        const double f = std::strtod(value.c_str(), &end);
        if (*end != '\0' || !(f > 0.0 && f <= 1.0)) badSelection(text, "does not give a share in (0, 1]");
        selection.rule = Rule::Share;
        selection.share = f;
    }
    return selection;
}

std::string LayerSelection::text() const {
    switch (rule) {
        case Rule::All: return "all";
        case Rule::Top: return "top:" + std::to_string(top);
        case Rule::Share: break;
    }
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "share:%g", share);
    return buffer;
}

std::vector<bool> keptLayers(const std::vector<double>& power, const std::vector<std::string>& names,
                             const LayerSelection& selection) {
    if (power.size() != names.size()) throw std::invalid_argument("keptLayers: a power per name");
    std::vector<bool> kept(power.size(), selection.rule == LayerSelection::Rule::All);
    if (selection.rule == LayerSelection::Rule::All) return kept;
    std::vector<size_t> rank(power.size());
    std::iota(rank.begin(), rank.end(), size_t{0});
    std::sort(rank.begin(), rank.end(), [&](size_t a, size_t b) {
        return power[a] != power[b] ? power[a] > power[b] : names[a] < names[b];
    });
    size_t keep = rank.size();
    if (selection.rule == LayerSelection::Rule::Top) {
        keep = std::min(keep, static_cast<size_t>(selection.top));
    } else {
        // The total summed in rank order, so that a share of 1 keeps every layer: the sum of all of
        // them is the total to the bit.
        double total = 0.0;
        for (size_t i : rank) total += power[i];
        double held = 0.0;
        keep = 0;
        while (keep < rank.size() && !(held >= selection.share * total)) held += power[rank[keep++]];
    }
    for (size_t k = 0; k < keep; ++k) kept[rank[k]] = true;
    return kept;
}

}  // namespace flare
