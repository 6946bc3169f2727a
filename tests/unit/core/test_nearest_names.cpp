// "Did you mean": edit distances against hand-counted values, and the nearest names of a shortened
// or mistyped one.
#include <gtest/gtest.h>

#include "flare/core/NearestNames.h"

namespace flare {
namespace {

TEST(NearestNames, EditDistancesAreTheHandCountedOnes) {
    EXPECT_EQ(editDistance("", ""), 0);
    EXPECT_EQ(editDistance("kitten", "sitting"), 3);  // k→s, e→i, +g
    EXPECT_EQ(editDistance("Zeis", "zeiss"), 1);      // case is ignored
    EXPECT_EQ(editDistance("abc", ""), 3);
    EXPECT_EQ(prefixEditDistance("nikon-af", "nikon-af-s-nikkor"), 0);
    EXPECT_EQ(prefixEditDistance("nikon-ax", "nikon-af-s-nikkor"), 1);
    EXPECT_EQ(prefixEditDistance("nikon-af-s-nikkor-70-200", "nikon-af-s-nikkor-70-200mm-f2.8g-ed-vr-ii"), 0);
}

TEST(NearestNames, ShortenedAndMistypedNamesFindTheirs) {
    const std::vector<std::string> names = {"nikon-af-s-nikkor-70-200mm-f2.8g-ed-vr-ii", "nikon-af-s-nikkor-70-200mm-f4g-ed-vr",
                                            "nikon-af-s-nikkor-24-70mm-f2.8g-ed", "canon-ef70-200mm-f4l-usm", "Zeiss",
                                            "Zenit"};
    const auto shortened = nearestNames("nikon-af-s-nikkor-70-200", names, 5);
    // Both 70-200s begin with it (0 edits), the 24-70 is 4 edits from a beginning (within 24 / 4),
    // the Canon 14.
    ASSERT_EQ(shortened.size(), 3u);
    EXPECT_EQ(shortened[0], "nikon-af-s-nikkor-70-200mm-f4g-ed-vr");  // 12 edits to the whole name
    EXPECT_EQ(shortened[1], "nikon-af-s-nikkor-70-200mm-f2.8g-ed-vr-ii");  // 17
    EXPECT_EQ(shortened[2], "nikon-af-s-nikkor-24-70mm-f2.8g-ed");
    EXPECT_EQ(nearestNames("Zeis", names, 5), std::vector<std::string>{"Zeiss"});
    EXPECT_EQ(nearestNames("canon-ef70-200mm-f4-usm", names, 1), std::vector<std::string>{"canon-ef70-200mm-f4l-usm"});
    EXPECT_TRUE(nearestNames("sigma-art", names, 5).empty());
}

}  // namespace
}  // namespace flare
