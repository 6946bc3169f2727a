#include "flare/scene/JsonTree.h"

#include <cstddef>
#include <iterator>

#include <nlohmann/json.hpp>

#include "flare/core/Error.h"

namespace flare::scenefile {

namespace {

// nlohmann's SAX events carry no position, so the input iterator records how many bytes the lexer
// has consumed; at each event that is the end of the token just read (plus one look-ahead byte
// after a number).
class CountingIterator {
public:
    using iterator_category = std::input_iterator_tag;
    using value_type = char;
    using difference_type = std::ptrdiff_t;
    using pointer = const char*;
    using reference = const char&;

    CountingIterator(const char* p, const char* begin, std::size_t* consumed)
        : p_(p), begin_(begin), consumed_(consumed) {}
    reference operator*() const { return *p_; }
    CountingIterator& operator++() {
        ++p_;
        *consumed_ = static_cast<std::size_t>(p_ - begin_);
        return *this;
    }
    CountingIterator operator++(int) {
        CountingIterator old = *this;
        ++*this;
        return old;
    }
    bool operator==(const CountingIterator& other) const { return p_ == other.p_; }
    bool operator!=(const CountingIterator& other) const { return p_ != other.p_; }

private:
    const char* p_;
    const char* begin_;
    std::size_t* consumed_;
};

class LineIndex {
public:
    explicit LineIndex(std::string_view text) : text_(text) {
        for (std::size_t i = 0; i < text.size(); ++i)
            if (text[i] == '\n') newlines_.push_back(i);
    }
    // 1-based line of byte `offset`.
    int lineOf(std::size_t offset) const {
        return 1 + static_cast<int>(std::lower_bound(newlines_.begin(), newlines_.end(), offset) - newlines_.begin());
    }
    // 1-based column of byte `offset`.
    int columnOf(std::size_t offset) const {
        const auto it = std::lower_bound(newlines_.begin(), newlines_.end(), offset);
        const std::size_t lineStart = it == newlines_.begin() ? 0 : *(it - 1) + 1;
        return 1 + static_cast<int>(offset - lineStart);
    }
    std::string_view text() const { return text_; }

private:
    std::string_view text_;
    std::vector<std::size_t> newlines_;
};

class TreeBuilder {
public:
    using json = nlohmann::json;

    TreeBuilder(const LineIndex& lines, const std::string& file) : lines_(lines), file_(file) {}

    Node& root() { return root_; }

    bool null() {
        add(Node::Kind::Null, false);
        return true;
    }
    bool boolean(bool value) {
        add(Node::Kind::Boolean, false).boolean = value;
        return true;
    }
    bool number_integer(json::number_integer_t value) {
        Node& n = add(Node::Kind::Integer, true);
        n.integer = value;
        n.number = static_cast<double>(value);
        return true;
    }
    bool number_unsigned(json::number_unsigned_t value) {
        Node& n = add(Node::Kind::Unsigned, true);
        n.unsignedValue = value;
        n.number = static_cast<double>(value);
        return true;
    }
    bool number_float(json::number_float_t value, const json::string_t&) {
        add(Node::Kind::Float, true).number = value;
        return true;
    }
    bool string(json::string_t& value) {
        add(Node::Kind::String, false).text = std::move(value);
        return true;
    }
    bool binary(json::binary_t&) { return true; }  // not produced by the JSON reader
    bool start_object(std::size_t) {
        stack_.push_back(&add(Node::Kind::Object, false));
        return true;
    }
    bool key(json::string_t& key) {
        stack_.back()->members.push_back({std::move(key), tokenLine(false), Node{}});
        return true;
    }
    bool end_object() {
        stack_.pop_back();
        return true;
    }
    bool start_array(std::size_t) {
        stack_.push_back(&add(Node::Kind::Array, false));
        return true;
    }
    bool end_array() {
        stack_.pop_back();
        return true;
    }
    bool parse_error(std::size_t position, const std::string& /*lastToken*/, const nlohmann::detail::exception& ex) {
        // `position` counts the bytes read, the offending one included.
        const std::size_t offset = std::min(position > 0 ? position - 1 : 0, lines_.text().size());
        std::string message = ex.what();
        // "[json.exception.parse_error.101] parse error at line 3, column 5: syntax error while
        // parsing object - unexpected '}'; expected string literal": keep the part after the
        // position, which we give ourselves.
        if (const std::size_t bracket = message.find("] "); message.rfind("[json.exception", 0) == 0 &&
                                                           bracket != std::string::npos)
            message = message.substr(bracket + 2);
        if (message.rfind("parse error", 0) == 0)
            if (const std::size_t colon = message.find(": "); colon != std::string::npos)
                message = message.substr(colon + 2);
        if (message.rfind("syntax error ", 0) == 0) message = message.substr(13);
        std::string hint;
        const std::string_view text = lines_.text();
        if (offset < text.size() && (text[offset] == '}' || text[offset] == ']')) {
            // A comma right before a closing bracket: the most common hand-editing slip.
            std::size_t q = offset;
            while (q > 0 && std::isspace(static_cast<unsigned char>(text[q - 1]))) --q;
            if (q > 0 && text[q - 1] == ',')
                hint = std::string(" (a trailing comma before '") + text[offset] + "'?)";
        }
        if (hint.empty() && (message.find("; expected '}'") != std::string::npos ||
                             message.find("; expected ']'") != std::string::npos))
            hint = " (a missing comma?)";
        const std::size_t reported = std::min(offset, lines_.text().empty() ? 0 : lines_.text().size() - 1);
        throw InputError(file_, lines_.lineOf(reported),
                         "invalid JSON at column " + std::to_string(lines_.columnOf(reported)) + ": " + message +
                             hint);
    }

private:
    // Line of the token the lexer has just read.
    int tokenLine(bool isNumber) const {
        if (consumed == 0) return 1;
        std::size_t q = consumed - 1;
        if (isNumber && q > 0) {
            // The lexer reads one byte past a number to find its end.
            const char c = lines_.text()[q];
            if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == 'e' || c == 'E' || c == '+' ||
                  c == '-'))
                --q;
        }
        return lines_.lineOf(q);
    }

    Node& add(Node::Kind kind, bool isNumber) {
        Node* node = nullptr;
        if (stack_.empty()) {
            node = &root_;
        } else if (stack_.back()->kind == Node::Kind::Array) {
            node = &stack_.back()->items.emplace_back();
        } else {
            node = &stack_.back()->members.back().value;
        }
        node->kind = kind;
        node->line = tokenLine(isNumber);
        return *node;
    }

    const LineIndex& lines_;
    const std::string& file_;
    Node root_;
    std::vector<Node*> stack_;

public:
    std::size_t consumed = 0;  // bytes read by the lexer, updated by CountingIterator
};

}  // namespace

Node parseTree(std::string_view text, const std::string& file) {
    const LineIndex lines(text);
    TreeBuilder builder(lines, file);
    const CountingIterator first(text.data(), text.data(), &builder.consumed);
    const CountingIterator last(text.data() + text.size(), text.data(), &builder.consumed);
    // Comments (// and /* */) are allowed so that scenes can be annotated.
    nlohmann::json::sax_parse(first, last, &builder, nlohmann::json::input_format_t::json, true, true);
    return std::move(builder.root());
}

}  // namespace flare::scenefile
