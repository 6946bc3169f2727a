// Checking a scene's JSON tree against the layout the scene format allows: typed reads that name
// the value's key path and line in every error ("lights[1].angular_diameter_deg"), unknown keys
// with a suggestion of the closest allowed one. Shared by the scene's readers (Scene.cpp,
// SceneLights.cpp, SceneScattering.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "flare/scene/JsonTree.h"

namespace flare::scenefile {

// Key paths: "a.b" and "a[3]".
std::string child(const std::string& path, const std::string& key);
std::string index(const std::string& path, std::size_t i);
// A value as an error message quotes it: "an array of 3 values", "the string \"x\"", "1.5".
std::string describe(const Node& node);
// A number as the user wrote it (shortest round trip), and a derived value to six digits.
std::string formatNumber(double value);
std::string formatDerived(double value);

class Checker {
public:
    // `topName`: what errors about the top-level object call it ("scene", "spec").
    explicit Checker(std::string file, std::string topName = "scene")
        : file_(std::move(file)), topName_(std::move(topName)) {}

    const std::string& file() const { return file_; }

    // Raises InputError(file, line, "path: problem").
    [[noreturn]] void fail(int line, const std::string& path, const std::string& problem) const;

    // Checks that `node` is an object whose keys are all in `allowed` (each given once).
    void object(const Node& node, const std::string& path, const std::vector<std::string>& allowed,
                const std::string& allowedFor = "") const;

    static const Member* find(const Node& object, std::string_view key);
    const Member& require(const Node& object, const std::string& path, const std::string& key,
                          const std::string& what = "") const;

    double number(const Node& node, const std::string& path) const;
    // A number in [lo, hi] (`openLo`: (lo, hi]).
    double numberIn(const Node& node, const std::string& path, double lo, double hi, const std::string& unit,
                    bool openLo = false) const;
    // An integer (an integral JSON number such as 1e7 counts) in [lo, hi].
    std::int64_t integerIn(const Node& node, const std::string& path, std::int64_t lo, std::int64_t hi) const;
    const std::string& string(const Node& node, const std::string& path) const;
    bool boolean(const Node& node, const std::string& path) const;
    // An array of exactly `count` numbers.
    const std::vector<Node>& numbers(const Node& node, const std::string& path, std::size_t count,
                                     const std::string& shape) const;

private:
    std::string file_;
    std::string topName_;
};

}  // namespace flare::scenefile
