#include "flare/core/NearestNames.h"

#include <algorithm>
#include <cctype>
#include <tuple>

namespace flare {

namespace {

bool same(char a, char b) {
    return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
}

// The last row of the edit-distance table of `a` against every beginning of `b`: row[j] is the
// distance from a to b's first j characters.
std::vector<int> lastRow(std::string_view a, std::string_view b) {
    std::vector<int> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = static_cast<int>(j);
    for (std::size_t i = 1; i <= a.size(); ++i) {
        int diagonal = row[0];
        row[0] = static_cast<int>(i);
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const int above = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (same(a[i - 1], b[j - 1]) ? 0 : 1)});
            diagonal = above;
        }
    }
    return row;
}

}  // namespace

int editDistance(std::string_view a, std::string_view b) { return lastRow(a, b).back(); }

int prefixEditDistance(std::string_view query, std::string_view name) {
    const std::vector<int> row = lastRow(query, name);
    return *std::min_element(row.begin(), row.end());
}

std::vector<std::string> nearestNames(std::string_view query, const std::vector<std::string>& names, size_t count) {
    const int limit = std::max<int>(1, static_cast<int>(query.size()) / 4);
    std::vector<std::tuple<int, int, std::string>> near;
    for (const std::string& name : names) {
        const int prefix = prefixEditDistance(query, name);
        if (prefix <= limit) near.emplace_back(prefix, editDistance(query, name), name);
    }
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());
    std::vector<std::string> out;
    for (size_t i = 0; i < near.size() && out.size() < count; ++i) out.push_back(std::get<2>(near[i]));
    return out;
}

}  // namespace flare
