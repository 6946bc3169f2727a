// --layers' selection: what it accepts, and which ghosts top:N and share:F keep.
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "flare/film/LayerSelection.h"

namespace flare {
namespace {

TEST(LayerSelection, ParsesAllTopAndShareAndRejectsTheRest) {
    EXPECT_EQ(LayerSelection::parse("all").rule, LayerSelection::Rule::All);
    const LayerSelection top = LayerSelection::parse("top:12");
    EXPECT_EQ(top.rule, LayerSelection::Rule::Top);
    EXPECT_EQ(top.top, 12);
    EXPECT_EQ(top.text(), "top:12");
    const LayerSelection share = LayerSelection::parse("share:0.95");
    EXPECT_EQ(share.rule, LayerSelection::Rule::Share);
    EXPECT_EQ(share.share, 0.95);
    EXPECT_EQ(share.text(), "share:0.95");
    EXPECT_EQ(LayerSelection::parse("share:1").share, 1.0);
    for (const char* bad : {"", "al", "top", "top:", "top:0", "top:-3", "top:2.5", "top:9999999999", "top: 3",
                            "share:0", "share:1.01", "share:-0.5", "share:nan", "share:0.5x", "best:3", "scene.json"})
        EXPECT_THROW(LayerSelection::parse(bad), std::invalid_argument) << bad;
    try {
        LayerSelection::parse("top:0");
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("share:F"), std::string::npos) << "says what is accepted";
    }
}

TEST(LayerSelection, TopKeepsTheStrongestAndShareTheFewestThatHoldTheShare) {
    const std::vector<std::string> names = {"ghost_02_01", "ghost_03_01", "ghost_03_02", "ghost_04_01", "ghost_04_02"};
    const std::vector<double> power = {1.0, 5.0, 2.0, 2.0, 0.5};  // total 10.5; ghost_03_02 and ghost_04_01 tie
    using Kept = std::vector<bool>;
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("all")), Kept(5, true));
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("top:1")), (Kept{false, true, false, false, false}));
    // A tie is broken by name: ghost_03_02 before ghost_04_01.
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("top:2")), (Kept{false, true, true, false, false}));
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("top:99")), Kept(5, true));
    // Shares: 5 / 10.5 = 0.476, 7 / 10.5 = 0.667, 9 / 10.5 = 0.857, 10 / 10.5 = 0.952, then all.
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("share:0.4")), (Kept{false, true, false, false, false}));
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("share:0.476")), (Kept{false, true, false, false, false}));
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("share:0.5")), (Kept{false, true, true, false, false}));
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("share:0.857")), (Kept{false, true, true, true, false}));
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("share:0.9")), (Kept{true, true, true, true, false}));
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("share:0.96")), Kept(5, true));
    EXPECT_EQ(keptLayers(power, names, LayerSelection::parse("share:1")), Kept(5, true));
    EXPECT_THROW(keptLayers({1.0}, names, LayerSelection{}), std::invalid_argument);
}

}  // namespace
}  // namespace flare
