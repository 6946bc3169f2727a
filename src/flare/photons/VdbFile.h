// A .vdb file checked before OpenVDB reads any of it (docs/volumes.md, "Hostile files").
//
// OpenVDB 10's reader trusts what a file declares: a chunk of values declared longer than the
// node's buffer is read into it (heap corruption: io::bloscFromStream and io::unzipFromStream read
// a stored chunk before comparing its size with the buffer's), counts of tiles or nodes are looped
// over at the end of the file, a mask or a metadata size that disagrees with the data shifts every
// read after it. So flare never hands a file's bytes to OpenVDB. VdbFile walks the file itself:
// the header, every grid descriptor and its offsets, the chosen grid's metadata, transform, tree
// topology and node values, checking each size, count, offset, mask and code against the file and
// the format and the tree's estimated memory against a budget; it decodes the compressed chunks
// (zlib, Blosc) into buffers of exactly the size the node needs; and it writes the one grid asked
// for as a plain OpenVDB stream (that grid alone, no compression, its transform rebuilt from its
// defining values) for OpenVDB to read. Every byte OpenVDB then sees has been checked.
//
// Reads file format versions 222 to 224 (OpenVDB 2.0 and later); the tree must be the standard
// float tree (Tree_float_5_4_3, values stored as float or half) to be read.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace flare {

// Larger .vdb files are refused before they are read (the whole file is held in memory).
inline constexpr std::uint64_t kMaxVdbFileBytes = std::uint64_t(2) << 30;
// A grid whose tree would take more memory than this (OpenVDB's node sizes times the nodes the
// file declares, counted while the topology is read) is refused: 2 GiB is about 9·10⁸ voxels in
// dense leaves; the shipped volumes take 1-20 MB.
inline constexpr std::uint64_t kMaxVdbGridMemoryBytes = std::uint64_t(2) << 30;

class VdbFile {
public:
    struct Grid {
        std::string name;       // its "name" metadata, else the name in its descriptor
        std::string valueType;  // as OpenVDB names it ("float", "vec3s", ...); the tree type if unknown
        std::string treeType;   // e.g. "Tree_float_5_4_3" (without the "_HalfFloat" suffix)
        std::size_t index = 0;  // position in the file
    };

    // Reads the file and checks its header and grid descriptors. Throws InputError(path, 0,
    // problem) for a missing, unreadable, oversized or malformed file.
    explicit VdbFile(const std::string& path);

    // Every grid of the file, in name order (stable: grids of one name in file order).
    const std::vector<Grid>& grids() const { return grids_; }

    // The grid (one of grids()), which must be a float grid, checked node by node and written as
    // an OpenVDB stream holding it alone, uncompressed. Throws InputError(path, 0, problem) naming
    // the grid, the node and the problem; also when the tree would take more than memoryBudget bytes.
    std::string checkedFloatGridStream(const Grid& grid, std::uint64_t memoryBudget = kMaxVdbGridMemoryBytes) const;

private:
    struct Descriptor {
        std::string uniqueName, treeType, parent;
        bool halfSuffix = false;
        std::size_t headerStart = 0, headerEnd = 0;  // the descriptor's name .. its three offsets
        std::size_t gridStart = 0, blockPos = 0, endPos = 0;  // 0 when the file has no offsets
    };

    std::string path_;
    std::string bytes_;
    std::size_t headerEnd_ = 0;  // end of the file header (magic .. UUID)
    std::uint32_t version_ = 0;
    bool hasOffsets_ = false;
    std::vector<Descriptor> descriptors_;
    std::vector<Grid> grids_;
};

}  // namespace flare
