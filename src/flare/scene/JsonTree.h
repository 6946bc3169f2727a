// A JSON tree that remembers the line of every value and key, so that a scene's errors can name
// the line of the offending value (nlohmann's own tree keeps no positions). Comments (// and
// /* */) are allowed, so that scenes can be annotated.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace flare::scenefile {

struct Member;

struct Node {
    enum class Kind { Null, Boolean, Integer, Unsigned, Float, String, Array, Object };
    Kind kind = Kind::Null;
    int line = 0;
    bool boolean = false;
    std::int64_t integer = 0;
    std::uint64_t unsignedValue = 0;
    double number = 0.0;  // every numeric kind, as a double
    std::string text;
    std::vector<Node> items;
    std::vector<Member> members;

    bool isNumber() const { return kind == Kind::Integer || kind == Kind::Unsigned || kind == Kind::Float; }
};

struct Member {
    std::string key;
    int keyLine = 0;
    Node value;
};

// Parses `text`; a syntax error raises InputError naming `file` and the line.
Node parseTree(std::string_view text, const std::string& file);

}  // namespace flare::scenefile
