#include "flare/photons/VolumeGrid.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include <glm/common.hpp>
#include <glm/mat3x3.hpp>
#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/tree/ValueAccessor.h>

#include "flare/core/Error.h"
#include "flare/core/OutputFiles.h"
#include "flare/photons/VdbFile.h"

namespace flare {

namespace {

// Metadata keys flare writes besides the grid name.
constexpr const char* kDescriptionKey = "description";
// constant() grids: the exact box the density is clipped to (the voxels may overhang it).
constexpr const char* kClipMinKey = "flare_clip_min_mm";
constexpr const char* kClipMaxKey = "flare_clip_max_mm";

void initializeOpenVdb() {
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

glm::dvec3 toGlm(const openvdb::Vec3d& v) { return {v.x(), v.y(), v.z()}; }
openvdb::Vec3d toVdb(const glm::dvec3& v) { return {v.x, v.y, v.z}; }

std::string formatNumber(double x) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.6g", x);
    return buffer;
}

std::string formatPoint(const glm::dvec3& p) {
    return "(" + formatNumber(p.x) + ", " + formatNumber(p.y) + ", " + formatNumber(p.z) + ")";
}

// "a (float), b (vec3s)" for the grids of a file, or "none".
std::string gridList(const std::vector<std::pair<std::string, std::string>>& grids) {
    std::string list;
    for (const auto& [name, type] : grids) list += (list.empty() ? "" : ", ") + ("\"" + name + "\" (" + type + ")");
    return list.empty() ? std::string("none") : list;
}

}  // namespace

// ---- Implementation -----------------------------------------------------------------------------

struct VolumeGrid::Impl {
    openvdb::FloatGrid::ConstPtr grid;
    std::string name, sourceFile, description;
    double voxelSizeMm = 0.0;
    glm::dvec3 boundsMinMm{0.0}, boundsMaxMm{0.0};  // the clip box of every lookup
    double minValue = 0.0, maxValue = 0.0, meanValue = 0.0;
    std::size_t activeVoxels = 0;
    // World (mm) → continuous index space: index = worldToIndex · p + worldToIndexOffset (linear
    // transforms only; voxel centres at integer indices).
    glm::dmat3 worldToIndex{1.0};
    glm::dvec3 worldToIndexOffset{0.0};
    // Integer voxel range lookups are clamped to (axis-aligned transforms; the whole int range
    // otherwise). Inside the clip box this only absorbs rounding at the box's faces.
    openvdb::Coord clampLo{std::numeric_limits<openvdb::Int32>::min()};
    openvdb::Coord clampHi{std::numeric_limits<openvdb::Int32>::max()};

    // Fills everything but grid, name, sourceFile and description from grid. Returns the problem
    // if the grid cannot be used as a density (no active voxels, negative or non-finite values, a
    // non-linear transform), else nothing. `clip` (constant() grids) narrows the bounds.
    std::optional<std::string> analyse(const std::optional<std::pair<glm::dvec3, glm::dvec3>>& clip);
};

std::optional<std::string> VolumeGrid::Impl::analyse(const std::optional<std::pair<glm::dvec3, glm::dvec3>>& clip) {
    Impl& impl = *this;
    const openvdb::FloatGrid& grid = *impl.grid;
    const openvdb::math::Transform& transform = grid.transform();
    if (!transform.isLinear())
        return std::string("grid \"") + grid.getName() +
               "\" has a non-linear (frustum) transform; flare reads grids with linear transforms only";

    const openvdb::FloatTree& tree = grid.tree();
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, sum = 0.0;
    std::size_t count = 0;
    for (auto it = tree.cbeginValueOn(); it; ++it) {
        const double v = *it;
        const auto n = static_cast<std::size_t>(it.getVoxelCount());
        if (!std::isfinite(v) || v < 0.0) {
            const openvdb::Coord c = it.getCoord();
            const glm::dvec3 p = toGlm(transform.indexToWorld(c));
            return std::string(std::isfinite(v) ? "negative" : "non-finite") + " density " + formatNumber(v) +
                   " in grid \"" + grid.getName() + "\" at voxel [" + std::to_string(c.x()) + ", " +
                   std::to_string(c.y()) + ", " + std::to_string(c.z()) + "] (" + formatPoint(p) +
                   " mm); densities must be finite and >= 0";
        }
        lo = std::min(lo, v);
        hi = std::max(hi, v);
        sum += v * static_cast<double>(n);
        count += n;
    }
    if (count == 0) return std::string("grid \"") + grid.getName() + "\" has no active voxels (an empty grid)";
    impl.minValue = lo;
    impl.maxValue = hi;
    impl.meanValue = sum / static_cast<double>(count);
    impl.activeVoxels = count;

    const openvdb::Vec3d voxel = transform.voxelSize();
    impl.voxelSizeMm = std::min({voxel.x(), voxel.y(), voxel.z()});

    // The affine world → index map, read off the transform itself (exact for linear maps).
    const glm::dvec3 origin = toGlm(transform.worldToIndex(openvdb::Vec3d(0.0)));
    for (int c = 0; c < 3; ++c) {
        openvdb::Vec3d e(0.0);
        e[c] = 1.0;
        impl.worldToIndex[c] = toGlm(transform.worldToIndex(e)) - origin;
    }
    impl.worldToIndexOffset = origin;

    // World box of the active voxels' full extent (the 8 corners of the index box ± ½ voxel).
    openvdb::CoordBBox box;
    tree.evalActiveVoxelBoundingBox(box);
    glm::dvec3 bMin(std::numeric_limits<double>::infinity()), bMax(-std::numeric_limits<double>::infinity());
    for (int corner = 0; corner < 8; ++corner) {
        const openvdb::Vec3d ijk((corner & 1 ? box.max().x() + 0.5 : box.min().x() - 0.5),
                                 (corner & 2 ? box.max().y() + 0.5 : box.min().y() - 0.5),
                                 (corner & 4 ? box.max().z() + 0.5 : box.min().z() - 0.5));
        const glm::dvec3 p = toGlm(transform.indexToWorld(ijk));
        bMin = glm::min(bMin, p);
        bMax = glm::max(bMax, p);
    }
    if (clip) {
        bMin = glm::max(bMin, clip->first);
        bMax = glm::min(bMax, clip->second);
        if (!(bMin.x <= bMax.x && bMin.y <= bMax.y && bMin.z <= bMax.z))
            return std::string("grid \"") + grid.getName() + "\": its clip box (" + kClipMinKey + ", " + kClipMaxKey +
                   ") does not meet its active voxels";
    }
    impl.boundsMinMm = bMin;
    impl.boundsMaxMm = bMax;

    // Axis-aligned transform (diagonal world → index matrix): clamping lookups to the active index
    // box is exact inside the clip box and removes rounding at its faces.
    const glm::dmat3& m = impl.worldToIndex;
    const bool axisAligned = m[0][1] == 0.0 && m[0][2] == 0.0 && m[1][0] == 0.0 && m[1][2] == 0.0 && m[2][0] == 0.0 &&
                             m[2][1] == 0.0;
    if (axisAligned) {
        impl.clampLo = box.min();
        impl.clampHi = box.max();
    }
    return std::nullopt;
}

namespace {

// The optional clip box stored in a grid's metadata by constant().
std::optional<std::pair<glm::dvec3, glm::dvec3>> clipFromMetadata(const openvdb::GridBase& grid) {
    const auto lo = grid.getMetadata<openvdb::Vec3DMetadata>(kClipMinKey);
    const auto hi = grid.getMetadata<openvdb::Vec3DMetadata>(kClipMaxKey);
    if (!lo || !hi) return std::nullopt;
    const glm::dvec3 a = toGlm(lo->value()), b = toGlm(hi->value());
    for (int c = 0; c < 3; ++c)
        if (!std::isfinite(a[c]) || !std::isfinite(b[c]) || a[c] > b[c]) return std::nullopt;
    return std::make_pair(a, b);
}

std::string stringMetadata(const openvdb::GridBase& grid, const char* key) {
    const auto m = grid.getMetadata<openvdb::StringMetadata>(key);
    return m ? m->value() : std::string();
}

}  // namespace

// ---- VolumeGrid ---------------------------------------------------------------------------------

VolumeGrid::VolumeGrid() = default;
VolumeGrid::~VolumeGrid() = default;
VolumeGrid::VolumeGrid(VolumeGrid&&) noexcept = default;
VolumeGrid& VolumeGrid::operator=(VolumeGrid&&) noexcept = default;
VolumeGrid::VolumeGrid(const VolumeGrid&) = default;
VolumeGrid& VolumeGrid::operator=(const VolumeGrid&) = default;
VolumeGrid::VolumeGrid(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}

std::vector<std::pair<std::string, std::string>> VolumeGrid::listGrids(const std::string& path) {
    initializeOpenVdb();
    std::vector<std::pair<std::string, std::string>> grids;
    const VdbFile file(path);
    for (const VdbFile::Grid& g : file.grids()) grids.emplace_back(g.name, g.valueType);
    return grids;
}

VolumeGrid VolumeGrid::load(const std::string& path, const std::string& gridName) {
    initializeOpenVdb();
    // The file is read and checked by VdbFile (header, descriptors, then the chosen grid node by
    // node) before OpenVDB sees any of it: OpenVDB's reader trusts the sizes and counts a file
    // declares (VdbFile.h).
    const VdbFile file(path);
    const std::vector<VdbFile::Grid>& grids = file.grids();
    const std::string floatType = openvdb::typeNameAsString<float>();  // "float"
    const auto listing = [&] {
        std::vector<std::pair<std::string, std::string>> list;
        for (const VdbFile::Grid& g : grids) list.emplace_back(g.name, g.valueType);
        return gridList(list);
    };

    const VdbFile::Grid* chosen = nullptr;
    if (gridName.empty()) {
        // "density" (the usual name of a fog volume) if the file has such a float grid, else the
        // first float grid in name order (as OpenVDB lists a file's grids; a .vdb keeps no other order).
        auto it = std::find_if(grids.begin(), grids.end(),
                               [&](const auto& g) { return g.name == "density" && g.valueType == floatType; });
        if (it == grids.end())
            it = std::find_if(grids.begin(), grids.end(), [&](const auto& g) { return g.valueType == floatType; });
        if (it == grids.end()) throw InputError(path, 0, "no float grid in the file (grids: " + listing() + ")");
        chosen = &*it;
    } else {
        // The first float grid of that name, else the first of that name (to say what it is).
        auto it = std::find_if(grids.begin(), grids.end(),
                               [&](const auto& g) { return g.name == gridName && g.valueType == floatType; });
        if (it == grids.end())
            it = std::find_if(grids.begin(), grids.end(), [&](const auto& g) { return g.name == gridName; });
        if (it == grids.end())
            throw InputError(path, 0, "no grid named \"" + gridName + "\" (grids: " + listing() + ")");
        if (it->valueType != floatType)
            throw InputError(path, 0, "grid \"" + gridName + "\" is a " + it->valueType + " grid; a density must be a " +
                                          floatType + " grid");
        chosen = &*it;
    }

    const std::string checked = file.checkedFloatGridStream(*chosen);
    auto impl = std::make_shared<Impl>();
    try {
        // The checked stream holds the one grid, uncompressed; the stream still throws on a short
        // read, as a second line of defence.
        std::istringstream in(checked, std::ios::binary);
        in.exceptions(std::ios::failbit | std::ios::badbit);
        openvdb::io::Stream stream(in, /*delayLoad=*/false);
        const openvdb::GridPtrVecPtr read = stream.getGrids();
        openvdb::FloatGrid::Ptr grid =
            read && read->size() == 1 ? openvdb::gridPtrCast<openvdb::FloatGrid>(read->front()) : nullptr;
        if (!grid) throw std::runtime_error("OpenVDB did not read it as one float grid");
        impl->grid = grid;
    } catch (const std::exception& e) {
        // Not expected after the checks: still the file's fault, not the program's.
        throw InputError(path, 0, "cannot read grid \"" + chosen->name + "\": " + e.what());
    }
    impl->name = impl->grid->getName();
    impl->sourceFile = path;
    impl->description = stringMetadata(*impl->grid, kDescriptionKey);
    if (const auto problem = impl->analyse(clipFromMetadata(*impl->grid))) throw InputError(path, 0, *problem);
    return VolumeGrid(std::move(impl));
}

VolumeGrid VolumeGrid::constant(double value, const glm::dvec3& minMm, const glm::dvec3& maxMm, double voxelMm) {
    initializeOpenVdb();
    if (!std::isfinite(value) || value < 0.0)
        throw std::invalid_argument("VolumeGrid::constant: the value must be finite and >= 0, not " + formatNumber(value));
    if (!std::isfinite(voxelMm) || !(voxelMm > 0.0))
        throw std::invalid_argument("VolumeGrid::constant: the voxel size must be > 0, not " + formatNumber(voxelMm));
    openvdb::Coord voxels;
    for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(minMm[c]) || !std::isfinite(maxMm[c]) || minMm[c] > maxMm[c])
            throw std::invalid_argument("VolumeGrid::constant: the box " + formatPoint(minMm) + " – " + formatPoint(maxMm) +
                                        " is not a box");
        const double n = std::ceil((maxMm[c] - minMm[c]) / voxelMm - 1e-9);
        if (n > 1 << 20) throw std::invalid_argument("VolumeGrid::constant: more than 2^20 voxels along an axis");
        voxels[c] = std::max(1, static_cast<int>(n));
    }
    // Voxel (i, j, k) spans [minMm + (i, j, k)·voxel, minMm + (i + 1, j + 1, k + 1)·voxel].
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
    openvdb::math::Transform::Ptr transform = openvdb::math::Transform::createLinearTransform(voxelMm);
    transform->postTranslate(toVdb(minMm + 0.5 * voxelMm));
    grid->setTransform(transform);
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    grid->insertMeta(kDescriptionKey, openvdb::StringMetadata("constant density " + formatNumber(value) + " over " +
                                                             formatPoint(minMm) + " – " + formatPoint(maxMm) + " mm"));
    grid->insertMeta(kClipMinKey, openvdb::Vec3DMetadata(toVdb(minMm)));
    grid->insertMeta(kClipMaxKey, openvdb::Vec3DMetadata(toVdb(maxMm)));
    grid->tree().fill(openvdb::CoordBBox(openvdb::Coord(0), voxels - openvdb::Coord(1)), static_cast<float>(value), true);

    auto impl = std::make_shared<Impl>();
    impl->grid = grid;
    impl->name = grid->getName();
    impl->description = stringMetadata(*grid, kDescriptionKey);
    if (const auto problem = impl->analyse(std::make_pair(minMm, maxMm)))
        throw std::invalid_argument("VolumeGrid::constant: " + *problem);
    return VolumeGrid(std::move(impl));
}

bool VolumeGrid::empty() const { return !impl_; }

namespace {
const std::string kNoString;
}

const std::string& VolumeGrid::name() const { return impl_ ? impl_->name : kNoString; }
const std::string& VolumeGrid::sourceFile() const { return impl_ ? impl_->sourceFile : kNoString; }
const std::string& VolumeGrid::description() const { return impl_ ? impl_->description : kNoString; }
double VolumeGrid::voxelSizeMm() const { return impl_ ? impl_->voxelSizeMm : 0.0; }
glm::dvec3 VolumeGrid::boundsMinMm() const { return impl_ ? impl_->boundsMinMm : glm::dvec3(0.0); }
glm::dvec3 VolumeGrid::boundsMaxMm() const { return impl_ ? impl_->boundsMaxMm : glm::dvec3(0.0); }
double VolumeGrid::minValue() const { return impl_ ? impl_->minValue : 0.0; }
double VolumeGrid::maxValue() const { return impl_ ? impl_->maxValue : 0.0; }
double VolumeGrid::meanValue() const { return impl_ ? impl_->meanValue : 0.0; }
std::size_t VolumeGrid::activeVoxelCount() const { return impl_ ? impl_->activeVoxels : 0; }

void VolumeGrid::forEachActiveBox(
    const std::function<void(const glm::dvec3& minMm, const glm::dvec3& maxMm, double value)>& visit) const {
    if (!impl_) return;
    const openvdb::math::Transform& transform = impl_->grid->transform();
    // Lookups round world → index in double precision: a point a few ulps outside a voxel's box
    // can still land on it. A millionth of a voxel is far above that and far below any cell size.
    const double margin = 1e-6 * impl_->voxelSizeMm;
    for (auto it = impl_->grid->tree().cbeginValueOn(); it; ++it) {
        const openvdb::CoordBBox box = it.getBoundingBox();
        glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
        for (int corner = 0; corner < 8; ++corner) {
            const openvdb::Vec3d ijk((corner & 1 ? box.max().x() + 0.5 : box.min().x() - 0.5),
                                     (corner & 2 ? box.max().y() + 0.5 : box.min().y() - 0.5),
                                     (corner & 4 ? box.max().z() + 0.5 : box.min().z() - 0.5));
            const glm::dvec3 p = toGlm(transform.indexToWorld(ijk));
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
        visit(lo - margin, hi + margin, static_cast<double>(*it));
    }
}

void VolumeGrid::save(OutputFiles& outputs, const std::string& path) const {
    if (!impl_) throw std::logic_error("VolumeGrid::save: the grid is empty");
    initializeOpenVdb();
    try {
        openvdb::io::File out(outputs.file(path));
        out.write(openvdb::GridCPtrVec{impl_->grid});
        out.close();
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot write " + path + ": " + e.what());
    }
}

void VolumeGrid::save(const std::string& path) const {
    if (!impl_) throw std::logic_error("VolumeGrid::save: the grid is empty");
    OutputFiles outputs;
    outputs.add(path);
    save(outputs, path);
    outputs.commit();
}

// ---- Sampler ------------------------------------------------------------------------------------

struct VolumeGrid::Sampler::Impl {
    // Unregistered accessor (IsSafe = false): the tree never changes after construction.
    using Accessor = openvdb::tree::ValueAccessor<const openvdb::FloatTree, false>;

    explicit Impl(std::shared_ptr<const VolumeGrid::Impl> g)
        : grid(std::move(g)),
          accessor(grid->grid->tree()),
          worldToIndex(grid->worldToIndex),
          offset(grid->worldToIndexOffset),
          lo(grid->boundsMinMm),
          hi(grid->boundsMaxMm),
          clampLo(grid->clampLo),
          clampHi(grid->clampHi) {}

    std::shared_ptr<const VolumeGrid::Impl> grid;  // keeps the tree alive
    Accessor accessor;
    glm::dmat3 worldToIndex;
    glm::dvec3 offset, lo, hi;
    openvdb::Coord clampLo, clampHi;
};

VolumeGrid::Sampler::Sampler() = default;
VolumeGrid::Sampler::~Sampler() = default;
VolumeGrid::Sampler::Sampler(Sampler&&) noexcept = default;
VolumeGrid::Sampler& VolumeGrid::Sampler::operator=(Sampler&&) noexcept = default;

VolumeGrid::Sampler VolumeGrid::sampler() const {
    Sampler s;
    if (impl_) s.impl_ = std::make_unique<Sampler::Impl>(impl_);
    return s;
}

double VolumeGrid::Sampler::densityAt(const glm::dvec3& pMm) {
    if (!impl_) return 0.0;
    Impl& s = *impl_;
    // Written so that a NaN coordinate fails the test.
    if (!(pMm.x >= s.lo.x && pMm.x <= s.hi.x && pMm.y >= s.lo.y && pMm.y <= s.hi.y && pMm.z >= s.lo.z &&
          pMm.z <= s.hi.z))
        return 0.0;
    const glm::dvec3 q = s.worldToIndex * pMm + s.offset;
    // Nearest voxel centre (box sampling): the value is constant over each voxel. Clamped before
    // the conversion to int: a file's transform can map a point inside the bounds to an index far
    // outside int's range (found by tests/fuzz's vdb target), and NaN goes to the low end.
    const auto nearest = [](double v, openvdb::Int32 lo, openvdb::Int32 hi) {
        const double r = std::floor(v + 0.5);
        return r >= lo ? (r <= hi ? static_cast<openvdb::Int32>(r) : hi) : lo;
    };
    const openvdb::Coord ijk(nearest(q.x, s.clampLo.x(), s.clampHi.x()), nearest(q.y, s.clampLo.y(), s.clampHi.y()),
                             nearest(q.z, s.clampLo.z(), s.clampHi.z()));
    float value = 0.0f;
    return s.accessor.probeValue(ijk, value) ? static_cast<double>(value) : 0.0;
}

// ---- Builder ------------------------------------------------------------------------------------

struct VolumeGrid::Builder::Impl {
    openvdb::FloatGrid::Ptr grid;
    openvdb::FloatGrid::Accessor accessor;
    explicit Impl(openvdb::FloatGrid::Ptr g) : grid(std::move(g)), accessor(grid->getAccessor()) {}
};

VolumeGrid::Builder::Builder(std::string name, double voxelMm, const glm::dvec3& cornerMm) {
    initializeOpenVdb();
    if (!std::isfinite(voxelMm) || !(voxelMm > 0.0))
        throw std::invalid_argument("VolumeGrid::Builder: the voxel size must be > 0, not " + formatNumber(voxelMm));
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
    openvdb::math::Transform::Ptr transform = openvdb::math::Transform::createLinearTransform(voxelMm);
    transform->postTranslate(toVdb(cornerMm + 0.5 * voxelMm));
    grid->setTransform(transform);
    grid->setName(std::move(name));
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    impl_ = std::make_unique<Impl>(std::move(grid));
}

VolumeGrid::Builder::~Builder() = default;
VolumeGrid::Builder::Builder(Builder&&) noexcept = default;
VolumeGrid::Builder& VolumeGrid::Builder::operator=(Builder&&) noexcept = default;

void VolumeGrid::Builder::set(int i, int j, int k, double value) {
    impl_->accessor.setValue(openvdb::Coord(i, j, k), static_cast<float>(value));
}

double VolumeGrid::Builder::get(int i, int j, int k) const {
    float value = 0.0f;
    return impl_->accessor.probeValue(openvdb::Coord(i, j, k), value) ? static_cast<double>(value) : 0.0;
}

glm::dvec3 VolumeGrid::Builder::voxelCentreMm(int i, int j, int k) const {
    return toGlm(impl_->grid->transform().indexToWorld(openvdb::Coord(i, j, k)));
}

VolumeGrid VolumeGrid::Builder::build(const std::string& description) {
    if (!impl_) throw std::logic_error("VolumeGrid::Builder::build: called twice");
    openvdb::FloatGrid::Ptr grid = impl_->grid;
    impl_.reset();
    if (!description.empty()) grid->insertMeta(kDescriptionKey, openvdb::StringMetadata(description));
    auto impl = std::make_shared<VolumeGrid::Impl>();
    impl->grid = grid;
    impl->name = grid->getName();
    impl->description = description;
    if (const auto problem = impl->analyse(std::nullopt)) throw std::invalid_argument(*problem);
    return VolumeGrid(std::move(impl));
}

}  // namespace flare
