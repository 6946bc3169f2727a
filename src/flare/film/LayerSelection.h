// Which per-ghost layers an image keeps. A scene with a zoom lens has hundreds of ghosts, most of
// them faint: a compositor wants the strongest as layers of their own and the rest together. The
// rule keeps all of them, the N strongest (`top:N`), or the strongest until they hold a share F of
// the ghosts' power (`share:F`); the others are summed into one layer, kOtherGhostsLayer, so that
// the layers still add up to the same image. The render applies it before its passes, to its
// estimate of each path's power (Render.h), so that the film holds only the kept layers.
#pragma once

#include <cstdint>
#include <string>
#include <vector>


namespace flare {

struct LayerSelection {
    enum class Rule : std::uint8_t { All, Top, Share };
    Rule rule = Rule::All;
    int top = 0;         // Top: N ≥ 1
    double share = 1.0;  // Share: F in (0, 1]

    // "all", "top:N" (an integer N ≥ 1) or "share:F" (a number 0 < F ≤ 1). Anything else throws
    // std::invalid_argument saying what is accepted.
    static LayerSelection parse(const std::string& text);
    std::string text() const;
};

// The layer holding the ghosts a selection leaves out (a name no ghost label takes: labels are
// `ghost_` and two-digit surface numbers).
inline constexpr const char* kOtherGhostsLayer = "ghost_other";

// Which of the named layers `selection` keeps, given each one's power (any common unit): the N
// strongest (Top), or the fewest strongest whose powers add up to at least F of their total
// (Share), ranked by power with equal powers by name; every one for All. Per layer, in the given
// order.
std::vector<bool> keptLayers(const std::vector<double>& power, const std::vector<std::string>& names,
                             const LayerSelection& selection);

}  // namespace flare
