#include "flare/photons/VdbFile.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string_view>
#include <system_error>
#include <unordered_set>

#include <blosc.h>
#include <openvdb/Grid.h>
#include <openvdb/Metadata.h>
#include <openvdb/math/Maps.h>
#include <openvdb/math/Transform.h>
#include <openvdb/openvdb.h>
#include <openvdb/version.h>
#include <zlib.h>

#include "flare/core/Error.h"

namespace flare {

static_assert(std::endian::native == std::endian::little, "VdbFile reads OpenVDB's little-endian files natively");

namespace {

constexpr std::int64_t kMagic = 0x56444220;  // OPENVDB_MAGIC: " BDV"
constexpr std::uint32_t kOldestVersion = openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION;  // 222
constexpr std::uint32_t kNewestVersion = openvdb::OPENVDB_FILE_VERSION;                       // 224
constexpr std::size_t kUuidLength = 36;
// More grids in a file, or metadata entries in one map, are refused (each takes a few dozen bytes
// of the file and a few hundred of memory).
constexpr std::uint64_t kMaxEntries = 100000;
constexpr const char* kHalfSuffix = "_HalfFloat";

// Per-grid compression flags (io::COMPRESS_*).
constexpr std::uint32_t kZip = 0x1, kActiveMask = 0x2, kBlosc = 0x4;

// The float tree's node types and their sizes in memory, for the budget.
using RootNode = openvdb::FloatTree::RootNodeType;
using Upper = RootNode::ChildNodeType;  // 32³ children of 16³ children of 8³ voxels
using Lower = Upper::ChildNodeType;
using Leaf = Lower::ChildNodeType;
constexpr std::uint64_t kRootEntryBytes = 96;  // a root table entry (std::map node)

std::string number(std::uint64_t n) { return std::to_string(n); }

std::string coordText(const std::array<std::int32_t, 3>& c) {
    return "[" + std::to_string(c[0]) + ", " + std::to_string(c[1]) + ", " + std::to_string(c[2]) + "]";
}

// Printable form of a name taken from a file: control bytes and bytes above 0x7e escaped.
std::string printable(std::string_view s) {
    std::string out;
    for (const char ch : s.substr(0, 200)) {
        const auto u = static_cast<unsigned char>(ch);
        if (u >= 0x20 && u < 0x7f && u != '"' && u != '\\') {
            out += ch;
        } else {
            char buffer[8];
            std::snprintf(buffer, sizeof buffer, "\\x%02x", u);
            out += buffer;
        }
    }
    return s.size() > 200 ? out + "..." : out;
}

// A read position in the file's bytes. Every read checks that the bytes are there and throws
// InputError(path, 0, problem + " (byte N)") when they are not.
class Cursor {
public:
    Cursor(const std::string& path, std::string_view data, std::size_t pos) : path_(&path), data_(data), pos_(pos) {}

    std::size_t pos() const { return pos_; }
    std::size_t left() const { return data_.size() - pos_; }
    // The bytes read since `from`.
    std::string_view since(std::size_t from) const { return data_.substr(from, pos_ - from); }

    [[noreturn]] void fail(const std::string& problem) const {
        throw InputError(*path_, 0, problem + " (at byte " + number(pos_) + " of " + number(data_.size()) + ")");
    }

    std::string_view take(std::uint64_t n, const std::string& what) {
        if (n > left())
            fail("the file ends inside " + what + " (" + number(n) + " bytes declared, " + number(left()) + " left)");
        const std::string_view s = data_.substr(pos_, static_cast<std::size_t>(n));
        pos_ += static_cast<std::size_t>(n);
        return s;
    }

    template <typename T>
    T get(const std::string& what) {
        T value;
        std::memcpy(&value, take(sizeof(T), what).data(), sizeof(T));
        return value;
    }

    // OpenVDB's strings: a 32-bit length, then the bytes.
    std::string_view string(const std::string& what) { return take(get<std::uint32_t>("the length of " + what), what); }

private:
    const std::string* path_;
    std::string_view data_;
    std::size_t pos_;
};

void putString(std::string& out, std::string_view s) {
    const auto n = static_cast<std::uint32_t>(s.size());
    out.append(reinterpret_cast<const char*>(&n), sizeof n);
    out.append(s);
}

template <typename T>
void putValue(std::string& out, const T& value) {
    out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// What flare needs of a grid's metadata, and the entries OpenVDB is given back.
struct Metadata {
    std::optional<std::string> name;
    std::string gridClass;
    bool half = false;   // "is_saved_as_half_float": values stored as 16-bit halves
    std::string kept;    // the entries passed on, serialized as OpenVDB reads them
    std::uint32_t keptCount = 0;
};

// A grid's metadata (io::MetaMap::readMeta). OpenVDB reads a registered fixed-size type with
// sizeof(T) bytes whatever size the entry declares, a string with the declared size, and anything
// else as raw bytes; flare passes on only strings and fixed-size values whose declared size is
// theirs, and drops the rest (unknown types, and "__delayedload", whose nested sizes OpenVDB
// trusts too but which only serves memory-mapped reading).
Metadata readMetadata(Cursor& c, const std::string& where) {
    Metadata meta;
    const auto count = c.get<std::uint32_t>(where + ": the metadata count");
    if (count > c.left() / 12) c.fail(where + ": " + number(count) + " metadata entries declared, more than the file can hold");
    if (count > kMaxEntries) c.fail(where + ": " + number(count) + " metadata entries, more than flare reads (" + number(kMaxEntries) + ")");
    std::unordered_set<std::string> seen;
    for (std::uint32_t i = 0; i < count; ++i) {
        const std::size_t start = c.pos();
        const std::string name(c.string(where + ": a metadata name"));
        const std::string type(c.string(where + ": the type of metadata \"" + printable(name) + "\""));
        const std::string entry = where + ": metadata \"" + printable(name) + "\" (" + printable(type) + ")";
        const auto size = c.get<std::uint32_t>(entry + ": its size");
        const std::string_view value = c.take(size, entry);
        if (!seen.insert(name).second) c.fail(entry + " is given twice");
        if (!openvdb::Metadata::isRegisteredType(type) || type.starts_with("__")) continue;  // dropped
        if (type != openvdb::StringMetadata::staticTypeName()) {
            const openvdb::Index32 expected = openvdb::Metadata::createMetadata(type)->size();
            if (size != expected)
                c.fail(entry + " holds " + number(size) + " bytes; a " + printable(type) + " takes " + number(expected));
            if (type == openvdb::BoolMetadata::staticTypeName() && static_cast<unsigned char>(value[0]) > 1)
                c.fail(entry + " is neither 0 nor 1");
        }
        if (name == openvdb::GridBase::META_GRID_NAME) {
            if (type != openvdb::StringMetadata::staticTypeName()) c.fail(entry + ": a grid's name must be a string");
            meta.name = std::string(value);
        } else if (name == openvdb::GridBase::META_GRID_CLASS) {
            if (type != openvdb::StringMetadata::staticTypeName()) c.fail(entry + ": a grid's class must be a string");
            meta.gridClass = std::string(value);
        } else if (name == openvdb::GridBase::META_SAVE_HALF_FLOAT) {
            if (type != openvdb::BoolMetadata::staticTypeName()) c.fail(entry + ": must be a bool");
            meta.half = value[0] != 0;
        }
        meta.kept.append(c.since(start));
        ++meta.keptCount;
    }
    return meta;
}

// The grid's transform (math::Transform::read), rebuilt from its defining values: the maps OpenVDB
// reads also store derived values (inverse scales, the inverse matrix) that it trusts; a rebuilt map
// computes them itself. Returns the transform as Transform::write writes it.
std::string readTransform(Cursor& c, const std::string& where) {
    const std::string type(c.string(where + ": the transform's type"));
    const auto vec3 = [&](const char* what) {
        openvdb::Vec3d v;
        for (int i = 0; i < 3; ++i) v[i] = c.get<double>(where + ": the transform's " + what);
        for (int i = 0; i < 3; ++i)
            if (!std::isfinite(v[i])) c.fail(where + ": the transform's " + what + " is not finite");
        return v;
    };
    const auto skipDerived = [&] { c.take(4 * 3 * sizeof(double), where + ": the transform"); };
    openvdb::math::MapBase::Ptr map;
    try {
        if (type == openvdb::math::ScaleMap::mapType() || type == openvdb::math::UniformScaleMap::mapType()) {
            const openvdb::Vec3d scale = vec3("scale");
            skipDerived();
            if (type == openvdb::math::ScaleMap::mapType()) {
                map = std::make_shared<openvdb::math::ScaleMap>(scale);
            } else {
                if (scale[0] != scale[1] || scale[0] != scale[2]) c.fail(where + ": a uniform scale transform with unequal scales");
                map = std::make_shared<openvdb::math::UniformScaleMap>(scale[0]);
            }
        } else if (type == openvdb::math::TranslationMap::mapType()) {
            map = std::make_shared<openvdb::math::TranslationMap>(vec3("translation"));
        } else if (type == openvdb::math::ScaleTranslateMap::mapType() ||
                   type == openvdb::math::UniformScaleTranslateMap::mapType()) {
            const openvdb::Vec3d translation = vec3("translation");
            const openvdb::Vec3d scale = vec3("scale");
            skipDerived();
            if (type == openvdb::math::ScaleTranslateMap::mapType()) {
                map = std::make_shared<openvdb::math::ScaleTranslateMap>(scale, translation);
            } else {
                if (scale[0] != scale[1] || scale[0] != scale[2]) c.fail(where + ": a uniform scale transform with unequal scales");
                map = std::make_shared<openvdb::math::UniformScaleTranslateMap>(scale[0], translation);
            }
        } else if (type == openvdb::math::AffineMap::mapType() || type == openvdb::math::UnitaryMap::mapType()) {
            openvdb::Mat4d m;
            for (int i = 0; i < 4; ++i)
                for (int j = 0; j < 4; ++j) {
                    m(i, j) = c.get<double>(where + ": the transform's matrix");
                    if (!std::isfinite(m(i, j))) c.fail(where + ": the transform's matrix is not finite");
                }
            if (type == openvdb::math::AffineMap::mapType()) map = std::make_shared<openvdb::math::AffineMap>(m);
            else map = std::make_shared<openvdb::math::UnitaryMap>(m);
        } else if (type == openvdb::math::NonlinearFrustumMap::mapType()) {
            c.fail(where + " has a non-linear (frustum) transform; flare reads grids with linear transforms only");
        } else {
            c.fail(where + ": unknown transform type \"" + printable(type) + "\"");
        }
        // Inside the try: Transform simplifies an affine map into a scale map where it can, and
        // that map checks its scales again (a matrix the affine map accepts can have a diagonal
        // too small for the scale map: tests/data/fuzz/vdb/affine-map-simplifies-to-zero-scale.vdb).
        std::ostringstream out;
        openvdb::math::Transform(map).write(out);
        return out.str();
    } catch (const openvdb::ArithmeticError& e) {
        // The maps' own checks: scales near zero, a singular or non-affine matrix.
        c.fail(where + ": its transform is degenerate (" + std::string(e.what()) + ")");
    }
}

// A node's mask of N bits, as OpenVDB stores it (64-bit words, bit i of word i / 64).
template <std::size_t Bits>
struct Mask {
    std::array<std::uint64_t, Bits / 64> words{};
    static constexpr std::size_t kBytes = Bits / 8;
    void load(std::string_view bytes) { std::memcpy(words.data(), bytes.data(), kBytes); }
    bool on(std::size_t i) const { return (words[i >> 6] >> (i & 63)) & 1u; }
    std::size_t count() const {
        std::size_t n = 0;
        for (const std::uint64_t w : words) n += static_cast<std::size_t>(std::popcount(w));
        return n;
    }
    bool meets(const Mask& other) const {
        for (std::size_t i = 0; i < words.size(); ++i)
            if (words[i] & other.words[i]) return true;
        return false;
    }
    bool operator==(const Mask&) const = default;
};

// One float tree (topology, then buffers): checked and, when `out` is given, written uncompressed.
class TreeReader {
public:
    TreeReader(Cursor& c, std::string* out, std::uint32_t compression, bool half, const std::string& grid,
               std::uint64_t memoryBudget)
        : c_(c), out_(out), compression_(compression), half_(half), grid_(grid), budget_(memoryBudget) {}

    void topology() {
        const auto bufferCount = c_.get<std::int32_t>(grid_ + ": the tree's buffer count");
        if (bufferCount != 1) fail("tree", "declares " + std::to_string(bufferCount) + " buffers per node, not 1");
        putValue(std::int32_t(1));
        copy(c_.take(sizeof(float), grid_ + ": the background value"));
        const auto tiles = c_.get<std::uint32_t>(grid_ + ": the root's tile count");
        const auto children = c_.get<std::uint32_t>(grid_ + ": the root's child count");
        putValue(tiles);
        putValue(children);
        // Each tile takes 17 bytes and each child at least 12 + 8192.
        if (tiles > c_.left() / 17 || children > c_.left() / (12 + 8192))
            fail("root node", number(tiles) + " tiles and " + number(children) +
                                  " children declared, more than the file can hold");
        std::vector<std::array<std::int32_t, 3>> tileKeys;
        for (std::uint32_t i = 0; i < tiles; ++i) {
            const auto key = rootKey(tileKeys.empty() ? nullptr : &tileKeys.back(), "root tile");
            copy(c_.take(sizeof(float), grid_ + ": a root tile's value"));
            const auto active = c_.get<std::uint8_t>(grid_ + ": a root tile's state");
            if (active > 1) fail("root tile at " + coordText(key), "its active flag is " + number(active) + ", not 0 or 1");
            putValue(active);
            tileKeys.push_back(key);
            charge(kRootEntryBytes);
        }
        std::optional<std::array<std::int32_t, 3>> previous;
        for (std::uint32_t i = 0; i < children; ++i) {
            const auto key = rootKey(previous ? &*previous : nullptr, "root child");
            if (std::binary_search(tileKeys.begin(), tileKeys.end(), key))
                fail("root child at " + coordText(key), "a tile holds the same place");
            previous = key;
            charge(kRootEntryBytes + sizeof(Upper));
            upperTopology(key);
        }
    }

    void buffers() {
        for (const LeafRecord& leaf : leaves_) {
            const std::string where = "leaf node at " + coordText(leaf.origin);
            Mask<Leaf::SIZE> mask;
            const std::string_view bytes = c_.take(mask.kBytes, grid_ + ": the value mask of the " + where);
            mask.load(bytes);
            if (!(mask == leaf.mask)) fail(where, "its value mask in the data differs from the one in the topology");
            copy(bytes);
            values(mask, where);
        }
    }

    std::uint64_t memoryBytes() const { return memory_; }

private:
    struct LeafRecord {
        std::array<std::int32_t, 3> origin;
        Mask<Leaf::SIZE> mask;
    };

    [[noreturn]] void fail(const std::string& where, const std::string& problem) const {
        c_.fail(grid_ + ": " + where + ": " + problem);
    }

    void copy(std::string_view bytes) {
        if (out_) out_->append(bytes);
    }
    template <typename T>
    void putValue(const T& value) {
        if (out_) flare::putValue(*out_, value);
    }

    void charge(std::uint64_t bytes) {
        memory_ += bytes;
        if (memory_ > budget_)
            fail("tree", "its nodes would take more than " + number(budget_ >> 20) + " MB of memory (flare's limit for a grid)");
    }

    // A root entry's key: aligned to the root's children, after the previous key (OpenVDB keeps
    // them in a map ordered by (x, y, z) and writes them in that order).
    std::array<std::int32_t, 3> rootKey(const std::array<std::int32_t, 3>* previous, const char* what) {
        std::array<std::int32_t, 3> key;
        for (int a = 0; a < 3; ++a) key[a] = c_.get<std::int32_t>(grid_ + ": the origin of a " + what);
        for (int a = 0; a < 3; ++a)
            if (key[a] & static_cast<std::int32_t>(Upper::DIM - 1))
                fail(std::string(what) + " at " + coordText(key), "its origin is not a multiple of " + number(Upper::DIM));
        if (previous && !(*previous < key))
            fail(std::string(what) + " at " + coordText(key), "out of order or repeated (after " + coordText(*previous) + ")");
        for (int a = 0; a < 3; ++a) putValue(key[a]);
        return key;
    }

    template <typename Node>
    static std::array<std::int32_t, 3> childOrigin(const std::array<std::int32_t, 3>& origin, std::size_t i) {
        constexpr std::size_t log2 = Node::LOG2DIM, childTotal = Node::ChildNodeType::TOTAL;
        const std::size_t local[3] = {i >> (2 * log2), (i >> log2) & ((1u << log2) - 1), i & ((1u << log2) - 1)};
        std::array<std::int32_t, 3> c;
        for (int a = 0; a < 3; ++a) c[a] = origin[a] + static_cast<std::int32_t>(local[a] << childTotal);
        return c;
    }

    // An internal node's masks and values (InternalNode::readTopology), then its children.
    template <typename Node, typename ChildVisit>
    void internalTopology(const std::array<std::int32_t, 3>& origin, const char* kind, ChildVisit visitChild) {
        const std::string where = std::string(kind) + " at " + coordText(origin);
        Mask<Node::NUM_VALUES> childMask, valueMask;
        const std::string_view childBytes = c_.take(childMask.kBytes, grid_ + ": the child mask of the " + where);
        const std::string_view valueBytes = c_.take(valueMask.kBytes, grid_ + ": the value mask of the " + where);
        childMask.load(childBytes);
        valueMask.load(valueBytes);
        if (childMask.meets(valueMask)) fail(where, "a place holds both a child and an active value");
        copy(childBytes);
        copy(valueBytes);
        values(valueMask, where);
        for (std::size_t i = 0; i < Node::NUM_VALUES; ++i)
            if (childMask.on(i)) visitChild(childOrigin<Node>(origin, i));
    }

    void upperTopology(const std::array<std::int32_t, 3>& origin) {
        internalTopology<Upper>(origin, "upper internal node", [&](const std::array<std::int32_t, 3>& child) {
            charge(sizeof(Lower));
            internalTopology<Lower>(child, "lower internal node", [&](const std::array<std::int32_t, 3>& leaf) {
                charge(sizeof(Leaf));
                LeafRecord record{leaf, {}};
                const std::string_view bytes =
                    c_.take(record.mask.kBytes, grid_ + ": the value mask of the leaf node at " + coordText(leaf));
                record.mask.load(bytes);
                copy(bytes);
                leaves_.push_back(record);
            });
        });
    }

    // A node's values (io::readCompressedValues): a code saying which inactive values are stored,
    // those values and a selection mask, then the values in one chunk, compressed or not.
    template <std::size_t Bits>
    void values(const Mask<Bits>& valueMask, const std::string& where) {
        const auto code = c_.get<std::int8_t>(grid_ + ": the value-compression code of the " + where);
        // io::NO_MASK_OR_INACTIVE_VALS (0) .. io::NO_MASK_AND_ALL_VALS (6)
        if (code < 0 || code > 6) fail(where, "unknown value-compression code " + std::to_string(code));
        putValue(code);
        if (code == 2 || code == 4 || code == 5) copy(c_.take(sizeof(float), grid_ + ": an inactive value of the " + where));
        if (code == 5) copy(c_.take(sizeof(float), grid_ + ": an inactive value of the " + where));
        if (code == 3 || code == 4 || code == 5)
            copy(c_.take(Mask<Bits>::kBytes, grid_ + ": the selection mask of the " + where));
        const std::size_t count = (compression_ & kActiveMask) && code != 6 ? valueMask.count() : Bits;
        if (half_ && count == 0) return;  // io::HalfReader reads nothing then
        chunk(count * (half_ ? 2 : sizeof(float)), where);
    }

    // One chunk of `bytes` bytes of values (io::readData): with zip or Blosc compression a 64-bit
    // size first, negative for a chunk stored uncompressed.
    void chunk(std::size_t bytes, const std::string& where) {
        if (!(compression_ & (kZip | kBlosc))) {
            copy(c_.take(bytes, grid_ + ": the values of the " + where));
            return;
        }
        const auto declared = c_.get<std::int64_t>(grid_ + ": the chunk size of the " + where);
        if (declared <= 0) {
            // OpenVDB reads -declared bytes into the node's buffer before comparing the sizes.
            const std::uint64_t stored = 0 - static_cast<std::uint64_t>(declared);
            if (stored != bytes)
                fail(where, "a stored chunk of " + number(stored) + " bytes where " + number(bytes) + " are expected");
            copy(c_.take(bytes, grid_ + ": the values of the " + where));
            return;
        }
        const std::string_view packed = c_.take(static_cast<std::uint64_t>(declared), grid_ + ": the compressed values of the " + where);
        std::string unpacked(bytes, '\0');
        if (compression_ & kBlosc) {
            // Blosc reads only what its header declares: checked first (blosc_cbuffer_validate), as
            // c-blosc's own fuzzing harness does before decompressing.
            std::size_t nbytes = 0, cbytes = 0, blocksize = 0;
            if (packed.size() < BLOSC_MIN_HEADER_LENGTH) fail(where, "a Blosc chunk shorter than its header");
            blosc_cbuffer_sizes(packed.data(), &nbytes, &cbytes, &blocksize);
            if (cbytes != packed.size())
                fail(where, "a Blosc chunk of " + number(packed.size()) + " bytes whose header says " + number(cbytes));
            if (nbytes != bytes)
                fail(where, "a Blosc chunk holding " + number(nbytes) + " bytes where " + number(bytes) + " are expected");
            if (blosc_cbuffer_validate(packed.data(), packed.size(), &nbytes) != 0) fail(where, "a malformed Blosc chunk");
            if (bytes > 0 && blosc_decompress_ctx(packed.data(), unpacked.data(), bytes, 1) != static_cast<int>(bytes))
                fail(where, "corrupt Blosc-compressed values");
        } else {
            char none = 0;
            uLongf length = bytes;
            const int status = uncompress(bytes > 0 ? reinterpret_cast<Bytef*>(unpacked.data()) : reinterpret_cast<Bytef*>(&none),
                                          &length, reinterpret_cast<const Bytef*>(packed.data()), packed.size());
            if (status != Z_OK || length != bytes) fail(where, "corrupt zip-compressed values");
        }
        copy(unpacked);
    }

    Cursor& c_;
    std::string* out_;
    std::uint32_t compression_;
    bool half_;
    const std::string& grid_;
    std::uint64_t budget_;
    std::uint64_t memory_ = 0;
    std::vector<LeafRecord> leaves_;
};

struct GridBody {
    Metadata meta;
    std::string transform;
    std::uint32_t compression = 0;
};

// A grid's compression flags, metadata and transform (the part every grid has).
GridBody readGridHead(Cursor& c, const std::string& where) {
    GridBody body;
    body.compression = c.get<std::uint32_t>(where + ": its compression flags");
    if (body.compression & ~(kZip | kActiveMask | kBlosc))
        c.fail(where + ": unknown compression flags " + number(body.compression));
    if ((body.compression & kZip) && (body.compression & kBlosc)) c.fail(where + ": both zip and Blosc compression");
    body.meta = readMetadata(c, where);
    return body;
}

}  // namespace

VdbFile::VdbFile(const std::string& path) : path_(path) {
    namespace fs = std::filesystem;
    openvdb::initialize();  // the registries of grid, map and metadata types
    std::error_code ec;
    const fs::file_status status = fs::status(path, ec);
    if (ec && ec != std::errc::no_such_file_or_directory) throw InputError(path, 0, "cannot read the file: " + ec.message());
    if (!fs::exists(status)) throw InputError(path, 0, "no such file");
    if (fs::is_directory(status)) throw InputError(path, 0, "is a directory, not a .vdb file");
    if (!fs::is_regular_file(status)) throw InputError(path, 0, "not a regular file");
    const std::uintmax_t size = fs::file_size(path, ec);
    if (ec) throw InputError(path, 0, "cannot read the file: " + ec.message());
    if (size > kMaxVdbFileBytes)
        throw InputError(path, 0, "a .vdb file of " + number(size) + " bytes, larger than flare reads (" +
                                      number(kMaxVdbFileBytes >> 20) + " MB)");
    {
        std::ifstream in(path, std::ios::binary);
        if (!in) throw InputError(path, 0, "cannot read the file: " + std::string(std::strerror(errno)));
        bytes_.resize(static_cast<std::size_t>(size));
        in.read(bytes_.data(), static_cast<std::streamsize>(size));
        if (in.gcount() != static_cast<std::streamsize>(size)) throw InputError(path, 0, "cannot read the file (it changed while read)");
    }

    Cursor c(path_, bytes_, 0);
    // The header (io::Archive::readHeader).
    if (bytes_.size() < 8 || c.get<std::int64_t>("the header") != kMagic)
        throw InputError(path, 0, "not an OpenVDB file (no VDB magic number at its start)");
    version_ = c.get<std::uint32_t>("the header");
    if (version_ < kOldestVersion || version_ > kNewestVersion)
        c.fail("an OpenVDB file of format version " + number(version_) + "; flare reads versions " +
               number(kOldestVersion) + " to " + number(kNewestVersion));
    c.take(2 * sizeof(std::uint32_t), "the header");  // the writing library's version
    hasOffsets_ = c.get<std::uint8_t>("the header") != 0;
    const std::string_view uuid = c.take(kUuidLength, "the header's UUID");
    for (std::size_t i = 0; i < kUuidLength; ++i) {
        const bool dash = i == 8 || i == 13 || i == 18 || i == 23;
        if (dash ? uuid[i] != '-' : !std::isxdigit(static_cast<unsigned char>(uuid[i])))
            c.fail("a malformed UUID in the header");
    }
    headerEnd_ = c.pos();
    readMetadata(c, "the file's metadata");  // file-level metadata: checked, not passed on

    const auto count = c.get<std::int32_t>("the grid count");
    // A descriptor takes at least 3 strings and 3 offsets.
    if (count < 0 || static_cast<std::uint64_t>(count) > c.left() / 36) c.fail("a grid count of " + std::to_string(count));
    if (static_cast<std::uint64_t>(count) > kMaxEntries)
        c.fail(std::to_string(count) + " grids, more than flare reads (" + number(kMaxEntries) + ")");
    for (std::int32_t g = 0; g < count; ++g) {
        const std::string label = "grid " + std::to_string(g + 1) + " of " + std::to_string(count);
        Descriptor d;
        d.headerStart = c.pos();
        d.uniqueName = std::string(c.string(label + ": its name"));
        d.treeType = std::string(c.string(label + ": its type"));
        if (d.treeType.ends_with(kHalfSuffix)) {
            d.halfSuffix = true;
            d.treeType.resize(d.treeType.size() - std::strlen(kHalfSuffix));
        }
        d.parent = std::string(c.string(label + ": its instance parent"));
        const auto gridPos = c.get<std::int64_t>(label + ": its offsets");
        const auto blockPos = c.get<std::int64_t>(label + ": its offsets");
        const auto endPos = c.get<std::int64_t>(label + ": its offsets");
        d.headerEnd = c.pos();
        d.gridStart = c.pos();
        const std::string where = "grid \"" + printable(d.uniqueName) + "\"";
        if (hasOffsets_) {
            // io::File writes the grid right after its descriptor, its buffers at blockPos (0 for
            // an instance, which has none) and the next descriptor at endPos.
            const bool blockFits = d.parent.empty() ? gridPos <= blockPos && blockPos <= endPos : blockPos == 0;
            if (gridPos != static_cast<std::int64_t>(c.pos()) || !blockFits || endPos < gridPos ||
                static_cast<std::uint64_t>(endPos) > bytes_.size())
                c.fail(where + ": its offsets " + std::to_string(gridPos) + ", " + std::to_string(blockPos) + ", " +
                       std::to_string(endPos) + " do not fit the file");
            d.blockPos = static_cast<std::size_t>(blockPos);
            d.endPos = static_cast<std::size_t>(endPos);
        }
        GridBody head = readGridHead(c, where);
        Grid grid;
        grid.name = head.meta.name ? *head.meta.name : d.uniqueName.substr(0, d.uniqueName.find('\x1e'));
        grid.treeType = d.treeType;
        grid.index = descriptors_.size();
        if (openvdb::GridBase::isRegistered(d.treeType)) grid.valueType = openvdb::GridBase::createGrid(d.treeType)->valueType();
        else grid.valueType = printable(d.treeType);
        if (hasOffsets_) {
            if (c.pos() > d.endPos) c.fail(where + ": its metadata runs past the end its descriptor gives");
            c = Cursor(path_, bytes_, d.endPos);
        } else {
            // No offsets (written to a stream): the grid must be walked to find the next one.
            readTransform(c, where);
            if (d.parent.empty()) {
                if (d.treeType != openvdb::FloatTree::treeType())
                    c.fail(where + ": a " + grid.valueType +
                           " grid in a file without grid offsets, which flare cannot step over");
                TreeReader tree(c, nullptr, head.compression, head.meta.half, where, kMaxVdbGridMemoryBytes);
                tree.topology();
                tree.buffers();
            }
        }
        descriptors_.push_back(std::move(d));
        grids_.push_back(std::move(grid));
    }
    std::stable_sort(grids_.begin(), grids_.end(), [](const Grid& a, const Grid& b) { return a.name < b.name; });
}

std::string VdbFile::checkedFloatGridStream(const Grid& grid, std::uint64_t memoryBudget) const {
    const Descriptor& d = descriptors_.at(grid.index);
    const std::string where = "grid \"" + printable(grid.name) + "\"";
    if (d.treeType != openvdb::FloatTree::treeType())
        throw InputError(path_, 0, where + " has the tree type " + printable(d.treeType) + "; flare reads float grids of the standard type " +
                                       openvdb::FloatTree::treeType());
    if (!d.parent.empty())
        throw InputError(path_, 0, where + " is an instance of grid \"" + printable(d.parent) +
                                       "\" (it shares that grid's tree); flare reads grids that hold their own tree");

    Cursor c(path_, bytes_, d.gridStart);
    GridBody body = readGridHead(c, where);
    if (body.meta.gridClass == "level set" || body.meta.gridClass == "staggered")
        c.fail(where + " is a " + body.meta.gridClass + " grid; a density is a fog volume (or of no class)");
    body.transform = readTransform(c, where);

    // The stream OpenVDB reads: this file's header, no file metadata, one grid.
    std::string out(bytes_.substr(0, headerEnd_));
    putValue(out, std::uint32_t(0));  // file metadata entries
    putValue(out, std::int32_t(1));   // grids
    putString(out, d.uniqueName);
    putString(out, d.treeType + (d.halfSuffix ? kHalfSuffix : ""));
    putString(out, "");  // no instance parent
    for (int i = 0; i < 3; ++i) putValue(out, std::int64_t(0));  // offsets: a stream has none
    putValue(out, body.compression & kActiveMask);
    std::uint32_t entries = body.meta.keptCount;
    std::string meta = body.meta.kept;
    if (!body.meta.name) {
        // The name from the descriptor, as the grid's name metadata.
        putString(meta, openvdb::GridBase::META_GRID_NAME);
        putString(meta, openvdb::StringMetadata::staticTypeName());
        putValue(meta, static_cast<std::uint32_t>(grid.name.size()));
        meta += grid.name;
        ++entries;
    }
    putValue(out, entries);
    out += meta;
    out += body.transform;

    TreeReader tree(c, &out, body.compression, body.meta.half, where, memoryBudget);
    tree.topology();
    if (hasOffsets_ && c.pos() != d.blockPos)
        c.fail(where + ": its tree's topology does not end where its descriptor puts its data (byte " + number(d.blockPos) +
               ")");
    tree.buffers();
    if (hasOffsets_ && c.pos() != d.endPos)
        c.fail(where + ": its tree's data does not end where its descriptor says (byte " + number(d.endPos) + ")");
    return out;
}

}  // namespace flare
