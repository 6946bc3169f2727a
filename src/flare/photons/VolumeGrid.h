// Relative scattering density inside a glass element, stored as an OpenVDB float grid
// (volumes/*.vdb; format and commands: docs/volumes.md).
//
// The grid's world space is the element's local frame in millimetres: x, y across the optical
// axis, z along it from the element's front vertex. The density is piecewise constant per voxel
// (box / nearest-voxel sampling) and 0 wherever no active voxel is, so maxValue() is an exact
// majorant for delta and ratio tracking: no densityAt() ever exceeds it.
//
// OpenVDB is hidden behind a pointer to implementation: only VolumeGrid.cpp includes it.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "flare/core/OutputFiles.h"

namespace flare {

class VolumeGrid {
public:
    // Loads the float grid named `gridName` ("" = the float grid named "density" if there is one,
    // else the first float grid in name order: OpenVDB lists a file's grids by name). Any problem
    // (missing or unreadable file, not a VDB file, no such grid, a grid that is not a float grid,
    // a non-linear (frustum) transform, negative or non-finite active values, no active voxels,
    // a level set, a corrupt or hostile file: VdbFile checks every byte before OpenVDB reads the
    // grid) throws InputError(path, 0, problem).
    static VolumeGrid load(const std::string& path, const std::string& gridName = "");

    // (name, value type) of every grid in a .vdb file, in name order (the type as OpenVDB names
    // it: "float", "double", "vec3s", "int32", ...). Throws InputError(path, 0, problem) as load() does.
    static std::vector<std::pair<std::string, std::string>> listGrids(const std::string& path);

    // One constant value over an axis-aligned box: densityAt() = value inside [minMm, maxMm]
    // (bounds included), 0 outside, exactly, whatever voxelMm is. The voxels start at minMm; when
    // the box is not a whole number of voxels the last voxel row overhangs maxMm in the tree, but
    // lookups are clipped to the box, so boundsMinMm()/boundsMaxMm() are exactly minMm/maxMm.
    // Throws std::invalid_argument for a negative or non-finite value, voxelMm <= 0, min > max.
    static VolumeGrid constant(double value, const glm::dvec3& minMm, const glm::dvec3& maxMm, double voxelMm);

    VolumeGrid();
    ~VolumeGrid();
    VolumeGrid(VolumeGrid&&) noexcept;
    VolumeGrid& operator=(VolumeGrid&&) noexcept;
    VolumeGrid(const VolumeGrid&);             // shares the (immutable) tree
    VolumeGrid& operator=(const VolumeGrid&);

    bool empty() const;                    // default-constructed or moved-from
    const std::string& name() const;       // grid name
    const std::string& sourceFile() const; // "" for constant() and makeVolume()
    const std::string& description() const;// the grid's "description" metadata ("" if none)
    double voxelSizeMm() const;            // voxel edge (the smallest edge for a non-uniform scale)
    // Axis-aligned box (world space, mm) holding every point where densityAt() can be non-zero:
    // the full extent of the active voxels (voxel centres ± half a voxel), or constant()'s box.
    glm::dvec3 boundsMinMm() const;
    glm::dvec3 boundsMaxMm() const;
    double minValue() const;               // over active voxels and tiles
    double maxValue() const;               // the majorant: no densityAt() exceeds it
    double meanValue() const;              // over active voxels (tiles weighted by their voxels)
    std::size_t activeVoxelCount() const;  // active tiles count with all their voxels

    // Calls visit(minMm, maxMm, value) once per active voxel and active tile: a world-space box
    // holding every point whose lookup lands on it (the voxel's index box ± ½ mapped to world space;
    // for a rotated grid the axis-aligned box around that), widened by a rounding margin. The
    // largest value among the boxes a region meets therefore bounds densityAt() in that region:
    // MajorantGrid builds its coarse maxima this way.
    void forEachActiveBox(const std::function<void(const glm::dvec3& minMm, const glm::dvec3& maxMm, double value)>& visit) const;

    // Density lookups for one thread. Holds an OpenVDB ValueAccessor (a cache of the last nodes
    // visited), which is not thread-safe: each thread or photon batch makes its own with
    // sampler(). A sampler keeps the grid's data alive on its own.
    class Sampler {
    public:
        Sampler();  // an empty sampler: densityAt() = 0 everywhere
        ~Sampler();
        Sampler(Sampler&&) noexcept;
        Sampler& operator=(Sampler&&) noexcept;
        Sampler(const Sampler&) = delete;
        Sampler& operator=(const Sampler&) = delete;

        // The value of the active voxel containing pMm (nearest voxel centre), 0 outside the
        // active region and outside the bounds; a NaN point gives 0. Never throws.
        double densityAt(const glm::dvec3& pMm);

    private:
        friend class VolumeGrid;
        struct Impl;
        std::unique_ptr<Impl> impl_;
    };
    Sampler sampler() const;

    // Writes a .vdb file holding one float grid named name() (with its description metadata),
    // all or nothing (OutputFiles: a temporary beside the target, renamed over it). Throws
    // std::runtime_error (path and reason) if the file cannot be written, std::logic_error for an
    // empty grid. The second form writes into `outputs`' temporary for `path`, moved into place by
    // their commit().
    void save(const std::string& path) const;
    void save(OutputFiles& outputs, const std::string& path) const;

    // Builds a grid voxel by voxel (makeVolume uses it). Voxel (i, j, k) is the box
    // [cornerMm + (i, j, k)·voxelMm, cornerMm + (i + 1, j + 1, k + 1)·voxelMm]; set() activates it.
    // build() checks the values as load() does (throws std::invalid_argument instead) and returns
    // the grid; the builder is then empty.
    class Builder {
    public:
        Builder(std::string name, double voxelMm, const glm::dvec3& cornerMm);
        ~Builder();
        Builder(Builder&&) noexcept;
        Builder& operator=(Builder&&) noexcept;
        void set(int i, int j, int k, double value);
        double get(int i, int j, int k) const;  // 0 for an inactive voxel
        glm::dvec3 voxelCentreMm(int i, int j, int k) const;
        VolumeGrid build(const std::string& description = "");

    private:
        struct Impl;
        std::unique_ptr<Impl> impl_;
    };

private:
    struct Impl;
    explicit VolumeGrid(std::shared_ptr<const Impl> impl);
    std::shared_ptr<const Impl> impl_;
};

}  // namespace flare
