// "Did you mean": the known names nearest to a mistyped one (a lens id, a maker). A name is near
// when few edits turn the query into it or into its beginning, so a shortened id
// ("nikon-af-s-nikkor-70-200") finds every id it begins, and a slip ("Zeis", "nikon-nikor-50mm")
// finds the name it missed.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace flare {

// Levenshtein distance (insertions, deletions, substitutions each 1), case-insensitive.
int editDistance(std::string_view a, std::string_view b);
// The fewest edits that turn `query` into some beginning of `name` (0 when name starts with query),
// case-insensitive.
int prefixEditDistance(std::string_view query, std::string_view name);

// Up to `count` of `names` nearest to `query`: those within max(1, |query| / 4) edits of a
// beginning of the name, the fewest edits first, then the fewest to the whole name, then by name.
std::vector<std::string> nearestNames(std::string_view query, const std::vector<std::string>& names, size_t count);

}  // namespace flare
