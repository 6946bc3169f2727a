// OpenVDB density grids for glass bulk scattering: VolumeGrid (load/save, constant boxes, the
// box-sampled lookups and their majorant, every load error), makeVolume (each kind stays in its
// cylinder and in its documented value range, determinism) and `flare volume make|info`.
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <glm/common.hpp>
#include <glm/vector_relational.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "TestUtil.h"
#include "flare/core/Error.h"
#include "flare/core/Random.h"
#include "flare/photons/VdbFile.h"
#include "flare/photons/VolumeGrid.h"
#include "flare/photons/VolumeMake.h"

namespace flare {
namespace {

namespace fs = std::filesystem;

// Densities are stored as 32-bit floats.
constexpr double kFloatTolerance = 1e-6;
// Random lookups per property test.
constexpr int kLookups = 20000;

const VolumeMakeOptions::Kind kAllKinds[] = {VolumeMakeOptions::Kind::Haze, VolumeMakeOptions::Kind::Striae,
                                             VolumeMakeOptions::Kind::Bubbles, VolumeMakeOptions::Kind::Inclusions};

// A small element, quick to fill at a fine voxel.
VolumeMakeOptions smallElement(VolumeMakeOptions::Kind kind, std::uint64_t seed = 1) {
    VolumeMakeOptions o;
    o.kind = kind;
    o.radiusMm = 3.0;
    o.thicknessMm = 1.5;
    o.voxelMm = 0.05;
    o.seed = seed;
    o.density = kind == VolumeMakeOptions::Kind::Inclusions ? 40.0 : 2.0;
    o.count = kind == VolumeMakeOptions::Kind::Striae ? 6 : kind == VolumeMakeOptions::Kind::Inclusions ? 5 : 20;
    o.featureMm = 0.15;
    return o;
}

glm::dvec3 randomPoint(Rng& rng, const glm::dvec3& lo, const glm::dvec3& hi) {
    return {lo.x + (hi.x - lo.x) * rng.uniform(), lo.y + (hi.y - lo.y) * rng.uniform(), lo.z + (hi.z - lo.z) * rng.uniform()};
}

// A fresh directory per test, removed afterwards.
class VolumeTest : public ::testing::Test {
protected:
    void SetUp() override {
        openvdb::initialize();
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("flare_volume_" + std::to_string(::getpid()) + "_" + info->test_suite_name() + "_" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    std::string path(const std::string& file) const { return (dir_ / file).string(); }

    // Writes `grids` with OpenVDB directly (grids flare itself never writes).
    std::string writeVdb(const std::string& file, const openvdb::GridPtrVec& grids) const {
        const std::string p = path(file);
        openvdb::io::File(p).write(grids);
        return p;
    }

    openvdb::FloatGrid::Ptr floatGrid(const std::string& name, float value) const {
        openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
        g->setName(name);
        g->setTransform(openvdb::math::Transform::createLinearTransform(0.5));
        g->tree().setValue(openvdb::Coord(1, 2, 3), value);
        g->tree().setValue(openvdb::Coord(4, 2, 3), 0.25f);
        return g;
    }

    // The InputError load() throws, which must name the file.
    void expectLoadError(const std::string& file, const std::string& gridName, const std::string& problemPart) const {
        try {
            VolumeGrid::load(file, gridName);
            ADD_FAILURE() << "no InputError for " << file << " grid \"" << gridName << "\"";
        } catch (const InputError& e) {
            EXPECT_EQ(e.file(), file);
            EXPECT_EQ(e.line(), 0);
            EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
            EXPECT_NE(e.problem().find(problemPart), std::string::npos) << "problem: " << e.problem();
        }
    }

    fs::path dir_;
};

using VolumeGridTest = VolumeTest;
using VolumeMakeTest = VolumeTest;
using VolumeCliTest = VolumeTest;

// ---- VolumeGrid: constant() -------------------------------------------------------------------------

TEST_F(VolumeGridTest, ConstantIsTheValueInsideTheBoxAndZeroOutside) {
    const glm::dvec3 lo(-1.0, -2.0, 0.0), hi(1.0, 2.0, 3.0);
    const VolumeGrid grid = VolumeGrid::constant(0.7, lo, hi, 0.1);
    ASSERT_FALSE(grid.empty());
    EXPECT_EQ(grid.boundsMinMm(), lo);
    EXPECT_EQ(grid.boundsMaxMm(), hi);
    EXPECT_DOUBLE_EQ(grid.voxelSizeMm(), 0.1);
    EXPECT_EQ(grid.maxValue(), static_cast<double>(0.7f));  // the stored float, exactly
    EXPECT_EQ(grid.minValue(), grid.maxValue());
    EXPECT_EQ(grid.activeVoxelCount(), 20u * 40u * 30u);
    EXPECT_TRUE(grid.sourceFile().empty());

    VolumeGrid::Sampler s = grid.sampler();
    Rng rng(7, 0);
    for (int n = 0; n < kLookups; ++n) {
        const glm::dvec3 p = randomPoint(rng, lo - 1.0, hi + 1.0);
        const bool inside = glm::all(glm::greaterThanEqual(p, lo)) && glm::all(glm::lessThanEqual(p, hi));
        ASSERT_EQ(s.densityAt(p), inside ? grid.maxValue() : 0.0) << p.x << " " << p.y << " " << p.z;
    }
    // The faces and corners belong to the box.
    EXPECT_EQ(s.densityAt(lo), grid.maxValue());
    EXPECT_EQ(s.densityAt(hi), grid.maxValue());
    EXPECT_EQ(s.densityAt({1.0, 0.0, 1.5}), grid.maxValue());
    EXPECT_EQ(s.densityAt({1.0 + 1e-9, 0.0, 1.5}), 0.0);
    EXPECT_EQ(s.densityAt({0.0, 0.0, -1e-9}), 0.0);
    EXPECT_EQ(s.densityAt({std::nan(""), 0.0, 1.0}), 0.0);
}

TEST_F(VolumeGridTest, ConstantBoxNeedNotBeAWholeNumberOfVoxels) {
    const glm::dvec3 lo(0.03, -0.2, 0.0), hi(1.05, 0.33, 0.5);
    const VolumeGrid grid = VolumeGrid::constant(2.0, lo, hi, 0.2);
    EXPECT_EQ(grid.boundsMinMm(), lo);
    EXPECT_EQ(grid.boundsMaxMm(), hi);
    VolumeGrid::Sampler s = grid.sampler();
    EXPECT_EQ(s.densityAt({1.049, 0.0, 0.25}), 2.0);
    EXPECT_EQ(s.densityAt({1.051, 0.0, 0.25}), 0.0);  // inside the overhanging voxel, outside the box
    EXPECT_EQ(s.densityAt({0.5, 0.329, 0.499}), 2.0);
    EXPECT_EQ(s.densityAt({0.5, 0.331, 0.25}), 0.0);
    EXPECT_EQ(s.densityAt(hi), 2.0);
}

TEST_F(VolumeGridTest, ConstantRejectsBadArguments) {
    EXPECT_THROW(VolumeGrid::constant(-1.0, glm::dvec3(0.0), glm::dvec3(1.0), 0.1), std::invalid_argument);
    EXPECT_THROW(VolumeGrid::constant(std::nan(""), glm::dvec3(0.0), glm::dvec3(1.0), 0.1), std::invalid_argument);
    EXPECT_THROW(VolumeGrid::constant(1.0, glm::dvec3(0.0), glm::dvec3(1.0), 0.0), std::invalid_argument);
    EXPECT_THROW(VolumeGrid::constant(1.0, glm::dvec3(1.0), glm::dvec3(0.0), 0.1), std::invalid_argument);
}

TEST_F(VolumeGridTest, DefaultGridIsEmptyAndZeroEverywhere) {
    const VolumeGrid grid;
    EXPECT_TRUE(grid.empty());
    EXPECT_EQ(grid.activeVoxelCount(), 0u);
    EXPECT_EQ(grid.maxValue(), 0.0);
    EXPECT_TRUE(grid.name().empty());
    VolumeGrid::Sampler s = grid.sampler();
    EXPECT_EQ(s.densityAt({0.0, 0.0, 0.0}), 0.0);
    EXPECT_THROW(grid.save(path("empty.vdb")), std::logic_error);
    EXPECT_FALSE(fs::exists(path("empty.vdb")));
}

TEST_F(VolumeGridTest, CopiesShareTheTreeAndSamplersOutliveTheGrid) {
    VolumeGrid::Sampler s;
    {
        const VolumeGrid grid = VolumeGrid::constant(3.0, glm::dvec3(0.0), glm::dvec3(1.0), 0.25);
        VolumeGrid copy = grid;
        EXPECT_EQ(copy.activeVoxelCount(), grid.activeVoxelCount());
        VolumeGrid moved = std::move(copy);
        EXPECT_EQ(moved.maxValue(), 3.0);
        s = moved.sampler();
    }
    EXPECT_EQ(s.densityAt({0.5, 0.5, 0.5}), 3.0);
}

// ---- VolumeGrid: save / load ------------------------------------------------------------------------

TEST_F(VolumeGridTest, SaveLoadRoundTripKeepsValuesBoundsVoxelAndMajorant) {
    const VolumeGrid made = makeVolume(smallElement(VolumeMakeOptions::Kind::Bubbles));
    const std::string file = path("bubbles.vdb");
    made.save(file);
    EXPECT_FALSE(fs::exists(file + ".partial"));

    const VolumeGrid loaded = VolumeGrid::load(file);
    EXPECT_EQ(loaded.name(), "density");
    EXPECT_EQ(loaded.sourceFile(), file);
    EXPECT_EQ(loaded.description(), made.description());
    EXPECT_NE(loaded.description().find("--kind bubbles"), std::string::npos) << loaded.description();
    EXPECT_NEAR(loaded.voxelSizeMm(), made.voxelSizeMm(), 1e-12);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(loaded.boundsMinMm()[c], made.boundsMinMm()[c], 1e-9);
        EXPECT_NEAR(loaded.boundsMaxMm()[c], made.boundsMaxMm()[c], 1e-9);
    }
    EXPECT_EQ(loaded.minValue(), made.minValue());
    EXPECT_EQ(loaded.maxValue(), made.maxValue());
    EXPECT_EQ(loaded.meanValue(), made.meanValue());
    EXPECT_EQ(loaded.activeVoxelCount(), made.activeVoxelCount());

    VolumeGrid::Sampler a = made.sampler(), b = loaded.sampler();
    Rng rng(3, 1);
    int nonZero = 0;
    for (int n = 0; n < kLookups; ++n) {
        const glm::dvec3 p = randomPoint(rng, made.boundsMinMm() - 0.2, made.boundsMaxMm() + 0.2);
        const double d = a.densityAt(p);
        ASSERT_EQ(b.densityAt(p), d);
        nonZero += d > 0.0;
    }
    EXPECT_GT(nonZero, 0);
    // Exactly at voxel centres too.
    const double v = made.voxelSizeMm();
    for (int n = 0; n < 2000; ++n) {
        const glm::dvec3 p = (glm::floor(randomPoint(rng, made.boundsMinMm(), made.boundsMaxMm()) / v) + 0.5) * v;
        ASSERT_EQ(b.densityAt(p), a.densityAt(p));
    }
}

TEST_F(VolumeGridTest, ConstantBoxSurvivesSaveAndLoad) {
    const glm::dvec3 lo(0.03, -0.2, 0.0), hi(1.05, 0.33, 0.5);
    const std::string file = path("box.vdb");
    VolumeGrid::constant(2.0, lo, hi, 0.2).save(file);
    const VolumeGrid grid = VolumeGrid::load(file);
    EXPECT_EQ(grid.boundsMinMm(), lo);
    EXPECT_EQ(grid.boundsMaxMm(), hi);
    VolumeGrid::Sampler s = grid.sampler();
    EXPECT_EQ(s.densityAt({1.049, 0.0, 0.25}), 2.0);
    EXPECT_EQ(s.densityAt({1.051, 0.0, 0.25}), 0.0);
}

TEST_F(VolumeGridTest, SaveToAMissingDirectoryThrowsAndWritesNothing) {
    const VolumeGrid grid = VolumeGrid::constant(1.0, glm::dvec3(0.0), glm::dvec3(1.0), 0.5);
    const std::string file = path("no/such/dir/x.vdb");
    EXPECT_THROW(grid.save(file), std::runtime_error);
    EXPECT_FALSE(fs::exists(file));
    EXPECT_FALSE(fs::exists(file + ".partial"));
}

TEST_F(VolumeGridTest, LoadPicksTheNamedGridOrTheFirstFloatGrid) {
    openvdb::Vec3SGrid::Ptr velocity = openvdb::Vec3SGrid::create();
    velocity->setName("velocity");
    velocity->tree().setValue(openvdb::Coord(0), openvdb::Vec3f(1.0f));
    const std::string file = writeVdb("three.vdb", {velocity, floatGrid("smoke", 0.5f), floatGrid("dust", 4.0f)});
    // Without a name: the first float grid in name order (OpenVDB keeps no file order)...
    const VolumeGrid first = VolumeGrid::load(file);
    EXPECT_EQ(first.name(), "dust");
    EXPECT_EQ(first.maxValue(), 4.0);
    // ... unless one is called "density".
    const std::string withDensity =
        writeVdb("four.vdb", {velocity, floatGrid("smoke", 0.5f), floatGrid("dust", 4.0f), floatGrid("density", 2.0f)});
    EXPECT_EQ(VolumeGrid::load(withDensity).name(), "density");
    EXPECT_EQ(VolumeGrid::load(withDensity, "smoke").maxValue(), 0.5);
    const VolumeGrid dust = VolumeGrid::load(file, "dust");
    EXPECT_EQ(dust.name(), "dust");
    EXPECT_EQ(dust.maxValue(), 4.0);
    EXPECT_EQ(dust.minValue(), 0.25);
    EXPECT_EQ(dust.activeVoxelCount(), 2u);
    EXPECT_DOUBLE_EQ(dust.voxelSizeMm(), 0.5);
    // Voxel (1, 2, 3) at 0.5 mm spans [0.25, 0.75] × [0.75, 1.25] × [1.25, 1.75].
    EXPECT_EQ(dust.boundsMinMm(), glm::dvec3(0.25, 0.75, 1.25));
    EXPECT_EQ(dust.boundsMaxMm(), glm::dvec3(2.25, 1.25, 1.75));
    VolumeGrid::Sampler s = dust.sampler();
    EXPECT_EQ(s.densityAt({0.5, 1.0, 1.5}), 4.0);
    EXPECT_EQ(s.densityAt({0.26, 0.76, 1.74}), 4.0);
    EXPECT_EQ(s.densityAt({1.0, 1.0, 1.5}), 0.0);  // inactive voxel (2, 2, 3) between the two
    EXPECT_EQ(s.densityAt({2.0, 1.0, 1.5}), 0.25);

    const auto grids = VolumeGrid::listGrids(file);
    ASSERT_EQ(grids.size(), 3u);
    EXPECT_EQ(grids[0], std::make_pair(std::string("dust"), std::string("float")));
    EXPECT_EQ(grids[2], std::make_pair(std::string("velocity"), std::string("vec3s")));
}

TEST_F(VolumeGridTest, InactiveVoxelsAndTheBackgroundReadAsZero) {
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(5.0f);  // a non-zero background
    g->setName("density");
    g->tree().setValue(openvdb::Coord(0), 1.0f);
    g->tree().setValueOff(openvdb::Coord(1, 0, 0), 9.0f);  // inactive voxel with a value
    const VolumeGrid grid = VolumeGrid::load(writeVdb("background.vdb", {g}));
    EXPECT_EQ(grid.maxValue(), 1.0);
    VolumeGrid::Sampler s = grid.sampler();
    EXPECT_EQ(s.densityAt({0.0, 0.0, 0.0}), 1.0);
    EXPECT_EQ(s.densityAt({1.0, 0.0, 0.0}), 0.0);
    EXPECT_EQ(s.densityAt({40.0, 0.0, 0.0}), 0.0);
}

TEST_F(VolumeGridTest, ActiveTilesCountWithAllTheirVoxels) {
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    g->tree().fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(15)), 0.5f, true);  // becomes tiles
    g->tree().setValue(openvdb::Coord(20, 0, 0), 0.75f);
    const VolumeGrid grid = VolumeGrid::load(writeVdb("tiles.vdb", {g}));
    EXPECT_EQ(grid.activeVoxelCount(), 16u * 16u * 16u + 1u);
    EXPECT_EQ(grid.maxValue(), 0.75);
    EXPECT_EQ(grid.minValue(), 0.5);
    EXPECT_NEAR(grid.meanValue(), (0.5 * 4096 + 0.75) / 4097.0, 1e-12);
    VolumeGrid::Sampler s = grid.sampler();
    EXPECT_EQ(s.densityAt({7.3, 2.0, 15.4}), 0.5);
}

// ---- VolumeGrid: every load error ---------------------------------------------------------------------

TEST_F(VolumeGridTest, LoadOfAMissingFileNamesIt) { expectLoadError(path("missing.vdb"), "", "no such file"); }

TEST_F(VolumeGridTest, LoadOfADirectoryFails) { expectLoadError(dir_.string(), "", "directory"); }

TEST_F(VolumeGridTest, LoadOfGarbageIsNotAVdb) {
    const std::string file = path("garbage.vdb");
    std::ofstream(file, std::ios::binary) << "this is not an OpenVDB file, just some text\n" << std::string(300, 'x');
    expectLoadError(file, "", "not an OpenVDB file");
    const std::string empty = path("empty.vdb");
    std::ofstream(empty, std::ios::binary).flush();
    expectLoadError(empty, "", "not an OpenVDB file");
}

TEST_F(VolumeGridTest, LoadOfATruncatedFileFails) {
    const std::string whole = path("whole.vdb");
    makeVolume(smallElement(VolumeMakeOptions::Kind::Haze)).save(whole);
    std::string bytes;
    {
        std::ifstream in(whole, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    ASSERT_GT(bytes.size(), 1000u);
    for (const double fraction : {0.05, 0.5, 0.9}) {
        const std::string cut = path("cut" + std::to_string(static_cast<int>(100 * fraction)) + ".vdb");
        std::ofstream(cut, std::ios::binary) << bytes.substr(0, static_cast<size_t>(fraction * bytes.size()));
        try {
            VolumeGrid::load(cut);
            ADD_FAILURE() << "a file cut at " << fraction << " loaded";
        } catch (const InputError& e) {
            EXPECT_EQ(e.file(), cut);
        }
    }
}

TEST_F(VolumeGridTest, LoadOfAVectorOrIntegerGridIsAWrongType) {
    openvdb::Vec3SGrid::Ptr vec = openvdb::Vec3SGrid::create();
    vec->setName("density");
    vec->tree().setValue(openvdb::Coord(0), openvdb::Vec3f(1.0f, 2.0f, 3.0f));
    const std::string vecFile = writeVdb("vec3.vdb", {vec});
    expectLoadError(vecFile, "density", "is a vec3s grid");
    expectLoadError(vecFile, "", "no float grid");

    openvdb::Int32Grid::Ptr ints = openvdb::Int32Grid::create(0);
    ints->setName("density");
    ints->tree().setValue(openvdb::Coord(0), 3);
    const std::string intFile = writeVdb("int32.vdb", {ints});
    expectLoadError(intFile, "density", "is a int32 grid");
    expectLoadError(intFile, "", "no float grid");

    openvdb::DoubleGrid::Ptr doubles = openvdb::DoubleGrid::create(0.0);
    doubles->setName("density");
    doubles->tree().setValue(openvdb::Coord(0), 0.5);
    expectLoadError(writeVdb("double.vdb", {doubles}), "density", "is a double grid");
}

TEST_F(VolumeGridTest, LoadOfAMissingGridNameListsTheGrids) {
    const std::string file = writeVdb("named.vdb", {floatGrid("smoke", 1.0f)});
    expectLoadError(file, "density", "no grid named \"density\"");
    expectLoadError(file, "density", "\"smoke\" (float)");
}

TEST_F(VolumeGridTest, LoadOfNegativeOrNonFiniteValuesFails) {
    expectLoadError(writeVdb("negative.vdb", {floatGrid("density", -0.5f)}), "", "negative density -0.5");
    expectLoadError(writeVdb("nan.vdb", {floatGrid("density", std::nanf(""))}), "", "non-finite density");
    expectLoadError(writeVdb("inf.vdb", {floatGrid("density", INFINITY)}), "", "non-finite density");
    // A negative value in an inactive voxel is not part of the density.
    openvdb::FloatGrid::Ptr g = floatGrid("density", 1.0f);
    g->tree().setValueOff(openvdb::Coord(9), -3.0f);
    EXPECT_NO_THROW(VolumeGrid::load(writeVdb("inactive-negative.vdb", {g})));
}

TEST_F(VolumeGridTest, LoadOfAnEmptyGridFails) {
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    expectLoadError(writeVdb("nothing.vdb", {g}), "", "no active voxels");
    expectLoadError(writeVdb("nogrids.vdb", {}), "", "no float grid");
}

TEST_F(VolumeGridTest, LoadOfAFrustumGridFails) {
    openvdb::FloatGrid::Ptr g = floatGrid("density", 1.0f);
    const openvdb::BBoxd box(openvdb::Vec3d(0.0), openvdb::Vec3d(10.0));
    g->setTransform(openvdb::math::Transform::createFrustumTransform(box, 0.5, 10.0, 1.0));
    expectLoadError(writeVdb("frustum.vdb", {g}), "", "non-linear");
}

TEST_F(VolumeGridTest, RotatedGridsAreSampledInTheirOwnFrame) {
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    openvdb::math::Transform::Ptr t = openvdb::math::Transform::createLinearTransform(0.5);
    t->postRotate(0.25 * openvdb::math::pi<double>(), openvdb::math::Z_AXIS);
    g->setTransform(t);
    g->tree().setValue(openvdb::Coord(2, 0, 0), 1.0f);  // centre at (√2/2, √2/2, 0) mm
    const VolumeGrid grid = VolumeGrid::load(writeVdb("rotated.vdb", {g}));
    const double c = std::sqrt(0.5);
    VolumeGrid::Sampler s = grid.sampler();
    EXPECT_EQ(s.densityAt({c, c, 0.0}), 1.0);
    EXPECT_EQ(s.densityAt({1.0, 0.0, 0.0}), 0.0);  // inside the bounding box, outside the voxel
    EXPECT_LE(grid.boundsMinMm().x, c - 0.25);
    EXPECT_GE(grid.boundsMaxMm().y, c + 0.25);
}

// ---- VolumeGrid: hostile files (VdbFile) -----------------------------------------------------------------

// The bytes of a file.
std::string readAll(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

void writeAll(const std::string& file, const std::string& bytes) {
    std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
}

// The file of issue 33: volumes/inclusions.vdb with 161 of its bytes, from byte 29 559 on,
// repeated there. OpenVDB read a chunk of values declared longer than its buffer into it
// (io::bloscFromStream reads a stored chunk before comparing the sizes): heap corruption, then
// "malloc(): corrupted top size" and SIGABRT.
std::string inclusionsWithDuplicatedBytes(const std::string& file) {
    const std::string bytes = readAll(test::sourcePath("volumes/inclusions.vdb"));
    constexpr std::size_t kAt = 29559, kLength = 161;
    writeAll(file, bytes.substr(0, kAt + kLength) + bytes.substr(kAt));
    return file;
}

TEST_F(VolumeGridTest, FileWithDuplicatedBytesFromTheFuzzCampaignIsRefused) {
    expectLoadError(inclusionsWithDuplicatedBytes(path("duplicated.vdb")), "", "grid \"density\"");
}

// The heap overflow itself: a leaf's one active value is stored as an uncompressed zip chunk of
// 4 bytes (size -4); declared as 1000 bytes, OpenVDB read 1000 bytes into the 4-byte buffer.
TEST_F(VolumeGridTest, StoredChunkLongerThanItsNodeIsRefused) {
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    g->tree().setValue(openvdb::Coord(0), 0.75f);
    const std::string file = path("chunk.vdb");
    openvdb::io::File out(file);
    out.setCompression(openvdb::io::COMPRESS_ZIP | openvdb::io::COMPRESS_ACTIVE_MASK);
    out.write({g});
    ASSERT_NO_THROW(VolumeGrid::load(file));
    std::string bytes = readAll(file);
    const std::int64_t stored = -4, longer = -1000;
    const float value = 0.75f;
    const std::string chunk = std::string(reinterpret_cast<const char*>(&stored), 8) +
                              std::string(reinterpret_cast<const char*>(&value), 4);
    const std::size_t at = bytes.find(chunk);
    ASSERT_NE(at, std::string::npos);
    ASSERT_EQ(bytes.find(chunk, at + 1), std::string::npos);
    bytes.replace(at, 8, std::string(reinterpret_cast<const char*>(&longer), 8));
    bytes += std::string(2000, '\x55');  // bytes for the overflow to copy
    writeAll(file, bytes);
    expectLoadError(file, "", "leaf node at [0, 0, 0]: a stored chunk of 1000 bytes where 4 are expected");
}

// Random damage of small files (bits flipped, bytes overwritten, spans repeated, removed or cut
// off), as the fuzzers do: every file loads or is refused with an InputError, and a loaded grid is
// usable. Under the sanitizers (scripts/test-sanitize.sh) also no memory error.
TEST_F(VolumeGridTest, DamagedFilesLoadOrAreRefusedCleanly) {
    openvdb::FloatGrid::Ptr speckles = floatGrid("density", 1.0f);
    for (int i = 0; i < 12; ++i) speckles->tree().setValue(openvdb::Coord(3 * i, i % 5, 20 - i), 0.1f * i);
    speckles->tree().addTile(1, openvdb::Coord(64), 0.5f, true);
    speckles->setGridClass(openvdb::GRID_FOG_VOLUME);  // Blosc (OpenVDB's default)
    const std::string blosc = writeVdb("blosc.vdb", {speckles});
    openvdb::FloatGrid::Ptr zipped = speckles->deepCopy();
    zipped->setGridClass(openvdb::GRID_UNKNOWN);
    zipped->setSaveFloatAsHalf(true);
    const std::string zip = path("zip.vdb");
    {
        openvdb::io::File out(zip);
        out.setCompression(openvdb::io::COMPRESS_ZIP | openvdb::io::COMPRESS_ACTIVE_MASK);
        out.write({zipped, floatGrid("smoke", 2.0f)});
    }
    std::mt19937 random(33);
    int loaded = 0, refused = 0;
    for (const std::string& seed : {blosc, zip}) {
        const std::string original = readAll(seed);
        ASSERT_NO_THROW(VolumeGrid::load(seed));
        for (int n = 0; n < 300; ++n) {
            std::string bytes = original;
            const auto at = [&](std::size_t size) { return std::uniform_int_distribution<std::size_t>(0, size - 1)(random); };
            const auto span = [&] { return std::uniform_int_distribution<std::size_t>(1, 200)(random); };
            for (int k = 0, edits = 1 + n % 3; k < edits && !bytes.empty(); ++k) {
                const std::size_t p = at(bytes.size());
                switch ((n / 3 + k) % 6) {
                    case 0: bytes[p] = static_cast<char>(bytes[p] ^ (1 << (random() % 8))); break;
                    case 1: bytes[p] = static_cast<char>(random()); break;
                    case 2: bytes.insert(p, bytes.substr(p, span())); break;
                    case 3: bytes.erase(p, span()); break;
                    case 4: bytes.resize(p); break;
                    default:
                        for (std::size_t b = p; b < std::min(bytes.size(), p + 8); ++b) bytes[b] = static_cast<char>(random());
                }
            }
            const std::string file = path("damaged.vdb");
            writeAll(file, bytes);
            try {
                const VolumeGrid grid = VolumeGrid::load(file);
                VolumeGrid::Sampler s = grid.sampler();
                const double d = s.densityAt(0.5 * (grid.boundsMinMm() + grid.boundsMaxMm()));
                EXPECT_TRUE(d >= 0.0 && d <= grid.maxValue());
                ++loaded;
            } catch (const InputError& e) {
                EXPECT_EQ(e.file(), file);
                ++refused;
            }
        }
    }
    EXPECT_GT(refused, 400);
    EXPECT_GT(loaded, 0);
}

TEST_F(VolumeGridTest, HalfFloatAndOffsetFreeFilesLoad) {
    openvdb::FloatGrid::Ptr g = floatGrid("density", 1.0f / 3.0f);
    g->setSaveFloatAsHalf(true);
    const VolumeGrid half = VolumeGrid::load(writeVdb("half.vdb", {g}));
    EXPECT_EQ(half.maxValue(), static_cast<double>(static_cast<float>(openvdb::math::half(1.0f / 3.0f))));
    // Written as a stream (no grid offsets): the loader walks the grids to find the one asked for.
    const std::string streamed = path("streamed.vdb");
    {
        std::ofstream out(streamed, std::ios::binary);
        openvdb::io::Stream(out).write({floatGrid("smoke", 2.0f), floatGrid("dust", 4.0f)});
    }
    EXPECT_EQ(VolumeGrid::load(streamed, "dust").maxValue(), 4.0);
    EXPECT_EQ(VolumeGrid::load(streamed).name(), "dust");
    EXPECT_EQ(VolumeGrid::listGrids(streamed).size(), 2u);
}

TEST_F(VolumeGridTest, LevelSetsInstancesAndOversizedTreesAreRefused) {
    openvdb::FloatGrid::Ptr level = floatGrid("density", 1.0f);
    level->setGridClass(openvdb::GRID_LEVEL_SET);
    expectLoadError(writeVdb("level-set.vdb", {level}), "", "is a level set grid");

    openvdb::FloatGrid::Ptr parent = floatGrid("density", 1.0f);
    openvdb::FloatGrid::Ptr instance = openvdb::FloatGrid::create(parent->treePtr());
    instance->setName("copy");
    expectLoadError(writeVdb("instance.vdb", {parent, instance}), "copy", "is an instance of grid");

    // A tree above the memory budget (one of 100 kB here; the default is 2 GiB).
    const VdbFile file(writeVdb("budget.vdb", {floatGrid("density", 1.0f)}));
    try {
        file.checkedFloatGridStream(file.grids().front(), 100000);
        ADD_FAILURE() << "no InputError";
    } catch (const InputError& e) {
        EXPECT_NE(e.problem().find("MB of memory"), std::string::npos) << e.problem();
    }
    EXPECT_NO_THROW(file.checkedFloatGridStream(file.grids().front()));
}

// ---- Sampler --------------------------------------------------------------------------------------

TEST_F(VolumeGridTest, DensityIsConstantOverEachVoxelAndNeverAboveTheMajorant) {
    const VolumeGrid grid = makeVolume(smallElement(VolumeMakeOptions::Kind::Haze));
    VolumeGrid::Sampler s = grid.sampler();
    const double v = grid.voxelSizeMm();
    Rng rng(11, 0);
    for (int n = 0; n < kLookups; ++n) {
        const glm::dvec3 p = randomPoint(rng, grid.boundsMinMm(), grid.boundsMaxMm());
        // Another point in the same voxel (voxels span [k v, (k + 1) v] for makeVolume grids).
        const glm::dvec3 cell = glm::floor(p / v);
        const glm::dvec3 q = (cell + glm::dvec3(0.05 + 0.9 * rng.uniform(), 0.05 + 0.9 * rng.uniform(),
                                                0.05 + 0.9 * rng.uniform())) * v;
        const double d = s.densityAt(p);
        ASSERT_EQ(s.densityAt(q), d);
        ASSERT_LE(d, grid.maxValue());
        ASSERT_GE(d, 0.0);
    }
}

// A sheared transform maps points inside the grid's (axis-aligned) bounds to index coordinates far
// beyond int's range: lookups are clamped before the conversion to int (undefined behaviour before,
// found by the vdb fuzz target with a file whose uniform scale map had been corrupted), and stay
// within the majorant.
TEST_F(VolumeGridTest, LookupsOfAGridWithAnExtremeTransformStayBounded) {
    openvdb::FloatGrid::Ptr g = floatGrid("density", 1.0f);
    openvdb::Mat4d shear = openvdb::Mat4d::identity();
    shear(0, 1) = 1e200;  // index x moves world y by 1e200 mm
    g->setTransform(openvdb::math::Transform::Ptr(
        new openvdb::math::Transform(openvdb::math::MapBase::Ptr(new openvdb::math::AffineMap(shear)))));
    const VolumeGrid grid = VolumeGrid::load(writeVdb("sheared.vdb", {g}));
    // A point inside the bounds whose index lies ~1e200 voxels away.
    const glm::dvec3 middle = 0.5 * (grid.boundsMinMm() + grid.boundsMaxMm());
    VolumeGrid::Sampler s = grid.sampler();
    EXPECT_EQ(s.densityAt(middle), 0.0);
    Rng rng(3, 4);
    for (int n = 0; n < 1000; ++n) {
        const double d = s.densityAt(randomPoint(rng, grid.boundsMinMm(), grid.boundsMaxMm()));
        ASSERT_GE(d, 0.0);
        ASSERT_LE(d, grid.maxValue());
    }
}

// That fuzzed file itself: its uniform scale map stores the scales (0.5, 0.5, 2.6e180) and an
// inverse of 2 (OpenVDB would use the one to map voxels to millimetres and the other back). The
// loader rebuilds every transform from its defining values and refuses this one.
TEST_F(VolumeGridTest, FileWithAnInconsistentTransformIsRefused) {
    expectLoadError(test::sourcePath("tests/data/fuzz/vdb/transform-maps-bounds-outside-int-range.vdb"), "",
                    "uniform scale transform with unequal scales");
}

// A fuzzed file whose root node declares billions of tiles and which ends early: OpenVDB's
// topology reader does not check its stream and looped at end of file (a hang); it also loaded a
// byte of the file into a bool (undefined behaviour). VdbFile refuses the file before OpenVDB reads
// any of it (its tree declares 1 650 614 882 buffers per node, and a tile count beyond the file).
TEST_F(VolumeGridTest, FileDeclaringMoreTilesThanItHoldsIsRefusedAtOnce) {
    const auto start = std::chrono::steady_clock::now();
    EXPECT_THROW(VolumeGrid::load(test::sourcePath("tests/data/volumes/root-tiles-declared-beyond-end-of-file.vdb")),
                 InputError);
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 10.0);
}

TEST_F(VolumeGridTest, SamplersOnManyThreadsAgreeWithOneThread) {
    const VolumeGrid grid = makeVolume(smallElement(VolumeMakeOptions::Kind::Striae));
    constexpr int kPoints = 100000;
    std::vector<glm::dvec3> points(kPoints);
    Rng rng(5, 0);
    for (auto& p : points) p = randomPoint(rng, grid.boundsMinMm(), grid.boundsMaxMm());
    std::vector<double> serial(kPoints), parallel(kPoints);
    VolumeGrid::Sampler s = grid.sampler();
    for (int n = 0; n < kPoints; ++n) serial[n] = s.densityAt(points[n]);
    tbb::parallel_for(tbb::blocked_range<int>(0, kPoints, 1000), [&](const tbb::blocked_range<int>& r) {
        VolumeGrid::Sampler local = grid.sampler();
        for (int n = r.begin(); n < r.end(); ++n) parallel[n] = local.densityAt(points[n]);
    });
    EXPECT_EQ(serial, parallel);
}

// ---- makeVolume ---------------------------------------------------------------------------------------

TEST_F(VolumeMakeTest, EveryKindStaysInItsCylinderAndValueRange) {
    for (const auto kind : kAllKinds) {
        SCOPED_TRACE(toString(kind));
        const VolumeMakeOptions o = smallElement(kind);
        const VolumeGrid grid = makeVolume(o);
        ASSERT_FALSE(grid.empty());
        EXPECT_GT(grid.activeVoxelCount(), 0u);
        EXPECT_EQ(grid.name(), "density");
        EXPECT_DOUBLE_EQ(grid.voxelSizeMm(), o.voxelMm);
        EXPECT_GE(grid.minValue(), 0.0);
        EXPECT_LE(grid.maxValue(), o.density * (1.0 + kFloatTolerance));
        EXPECT_GT(grid.maxValue(), 0.0);
        const double eps = 1e-9;
        EXPECT_GE(grid.boundsMinMm().x, -o.radiusMm - eps);
        EXPECT_GE(grid.boundsMinMm().y, -o.radiusMm - eps);
        EXPECT_GE(grid.boundsMinMm().z, -eps);
        EXPECT_LE(grid.boundsMaxMm().x, o.radiusMm + eps);
        EXPECT_LE(grid.boundsMaxMm().y, o.radiusMm + eps);
        EXPECT_LE(grid.boundsMaxMm().z, o.thicknessMm + eps);

        // Random points over a box larger than the cylinder: any density lies inside the cylinder,
        // and none exceeds the majorant.
        VolumeGrid::Sampler s = grid.sampler();
        Rng rng(17, static_cast<std::uint64_t>(kind));
        double largest = 0.0;
        int nonZero = 0;
        for (int n = 0; n < 5 * kLookups; ++n) {
            const glm::dvec3 p = randomPoint(rng, {-o.radiusMm - 0.5, -o.radiusMm - 0.5, -0.5},
                                             {o.radiusMm + 0.5, o.radiusMm + 0.5, o.thicknessMm + 0.5});
            const double d = s.densityAt(p);
            ASSERT_GE(d, 0.0);
            ASSERT_LE(d, grid.maxValue());
            if (d > 0.0) {
                ++nonZero;
                ASSERT_LE(p.x * p.x + p.y * p.y, o.radiusMm * o.radiusMm) << p.x << " " << p.y;
                ASSERT_GE(p.z, 0.0);
                ASSERT_LE(p.z, o.thicknessMm);
            }
            largest = std::max(largest, d);
        }
        if (kind != VolumeMakeOptions::Kind::Inclusions) EXPECT_GT(nonZero, 0);  // stones are too small to hit
    }
}

TEST_F(VolumeMakeTest, HazeFillsTheWholeCylinderBetweenItsDocumentedBounds) {
    VolumeMakeOptions o = smallElement(VolumeMakeOptions::Kind::Haze);
    o.variation = 0.4;
    const VolumeGrid grid = makeVolume(o);
    EXPECT_NEAR(grid.minValue(), (1.0 - o.variation) * o.density, kFloatTolerance);
    EXPECT_NEAR(grid.maxValue(), o.density, kFloatTolerance);
    // Every voxel wholly inside the cylinder, counted independently.
    const int n = static_cast<int>(std::ceil(o.radiusMm / o.voxelMm)), layers = static_cast<int>(o.thicknessMm / o.voxelMm + 1e-9);
    std::size_t inside = 0;
    for (int i = -n; i < n; ++i)
        for (int j = -n; j < n; ++j) {
            const double x = std::max(std::abs(i * o.voxelMm), std::abs((i + 1) * o.voxelMm));
            const double y = std::max(std::abs(j * o.voxelMm), std::abs((j + 1) * o.voxelMm));
            if (x * x + y * y <= o.radiusMm * o.radiusMm * (1 + 1e-12)) inside += layers;
        }
    EXPECT_EQ(grid.activeVoxelCount(), inside);
    // Smooth: neighbouring voxels differ by a small fraction of the range.
    VolumeGrid::Sampler s = grid.sampler();
    Rng rng(2, 0);
    for (int k = 0; k < 2000; ++k) {
        const glm::dvec3 p = randomPoint(rng, {-2.0, -2.0, 0.1}, {2.0, 2.0, 1.4});
        const double a = s.densityAt(p), b = s.densityAt(p + glm::dvec3(o.voxelMm, 0.0, 0.0));
        ASSERT_GT(a, 0.0);
        ASSERT_LT(std::abs(a - b), 0.1 * o.density);
    }
}

TEST_F(VolumeMakeTest, StriaeAreThinSheetsRunningAlongZ) {
    const VolumeMakeOptions o = smallElement(VolumeMakeOptions::Kind::Striae);
    const VolumeGrid grid = makeVolume(o);
    const double cylinderVoxels = M_PI * o.radiusMm * o.radiusMm * o.thicknessMm / std::pow(o.voxelMm, 3);
    EXPECT_LT(static_cast<double>(grid.activeVoxelCount()), 0.3 * cylinderVoxels);  // sparse
    // A point on a sheet mostly has the sheet a voxel above and below it too (sheets contain z).
    VolumeGrid::Sampler s = grid.sampler();
    Rng rng(4, 0);
    int onSheet = 0, continued = 0;
    for (int n = 0; n < 5 * kLookups; ++n) {
        const glm::dvec3 p = randomPoint(rng, {-2.5, -2.5, 0.2}, {2.5, 2.5, 1.3});
        if (s.densityAt(p) < 0.2 * o.density) continue;
        ++onSheet;
        continued += s.densityAt(p + glm::dvec3(0.0, 0.0, o.voxelMm)) > 0.0 && s.densityAt(p - glm::dvec3(0.0, 0.0, o.voxelMm)) > 0.0;
    }
    ASSERT_GT(onSheet, 50);
    EXPECT_GT(continued, 0.9 * onSheet);
}

TEST_F(VolumeMakeTest, BubblesHoldTheVolumeOfTheirSpheres) {
    VolumeMakeOptions o = smallElement(VolumeMakeOptions::Kind::Bubbles);
    o.count = 1;
    o.featureMm = 0.4;  // radius in [0.2, 0.6] mm
    const VolumeGrid grid = makeVolume(o);
    const double voxelVolume = std::pow(o.voxelMm, 3);
    const double volume = grid.meanValue() * static_cast<double>(grid.activeVoxelCount()) * voxelVolume / o.density;
    EXPECT_GE(volume, 4.0 / 3.0 * M_PI * std::pow(0.2, 3) * 0.97);
    EXPECT_LE(volume, 4.0 / 3.0 * M_PI * std::pow(0.6, 3) * 1.03);
    // Its extent is a sphere's: equal along the three axes, within a voxel.
    const glm::dvec3 size = grid.boundsMaxMm() - grid.boundsMinMm();
    EXPECT_NEAR(size.x, size.y, 1.01 * o.voxelMm);
    EXPECT_NEAR(size.x, size.z, 1.01 * o.voxelMm);
    // And the volume is that of a sphere of the measured diameter.
    const double r = 0.5 * (size.x + size.y + size.z) / 3.0;
    EXPECT_NEAR(volume, 4.0 / 3.0 * M_PI * r * r * r, 0.25 * 4.0 / 3.0 * M_PI * r * r * r);
    EXPECT_EQ(grid.maxValue(), o.density);  // the inside is solid
}

// Σ value × voxel volume / density: the volume the features occupy, in mm³.
double featureVolume(const VolumeGrid& grid, double density) {
    return grid.meanValue() * static_cast<double>(grid.activeVoxelCount()) * std::pow(grid.voxelSizeMm(), 3) / density;
}

TEST_F(VolumeMakeTest, FeatureVolumesDoNotDependOnTheVoxelSize) {
    // The radii are drawn the same whatever the voxel; each bubble's voxels hold its exact volume.
    for (const auto kind : {VolumeMakeOptions::Kind::Bubbles, VolumeMakeOptions::Kind::Inclusions}) {
        SCOPED_TRACE(toString(kind));
        VolumeMakeOptions fine = smallElement(kind), coarse = fine;
        fine.density = coarse.density = 1.0;
        fine.count = coarse.count = 6;
        fine.voxelMm = 0.03;
        coarse.voxelMm = 0.12;
        const double a = featureVolume(makeVolume(fine), 1.0), b = featureVolume(makeVolume(coarse), 1.0);
        EXPECT_GT(a, 0.0);
        EXPECT_NEAR(b, a, 0.01 * a);
    }
}

TEST_F(VolumeMakeTest, FeaturesFarSmallerThanAVoxelAreNotLost) {
    VolumeMakeOptions o = smallElement(VolumeMakeOptions::Kind::Bubbles);
    o.count = 10;
    o.featureMm = 0.005;  // radius 2.5–7.5 µm in 50 µm voxels
    o.density = 1.0;
    const VolumeGrid grid = makeVolume(o);
    EXPECT_LE(grid.activeVoxelCount(), 8u * o.count);  // a speck may straddle voxel faces
    const double one = 4.0 / 3.0 * M_PI;
    EXPECT_GE(featureVolume(grid, 1.0), o.count * one * std::pow(0.5 * o.featureMm, 3) * (1.0 - kFloatTolerance));
    EXPECT_LE(featureVolume(grid, 1.0), o.count * one * std::pow(1.5 * o.featureMm, 3) * (1.0 + kFloatTolerance));
}

TEST_F(VolumeMakeTest, InclusionsAreAFewDenseSpecks) {
    const VolumeMakeOptions o = smallElement(VolumeMakeOptions::Kind::Inclusions);
    const VolumeGrid grid = makeVolume(o);
    // Each stone fits in a box of its diameter plus a voxel.
    const double box = std::pow(o.featureMm / o.voxelMm + 2.0, 3);
    EXPECT_LE(static_cast<double>(grid.activeVoxelCount()), o.count * box);
    EXPECT_GT(grid.maxValue(), 0.5 * o.density);
    EXPECT_LE(grid.maxValue(), o.density * (1.0 + kFloatTolerance));
}

TEST_F(VolumeMakeTest, SameSeedSameGridOtherSeedOtherGrid) {
    for (const auto kind : kAllKinds) {
        SCOPED_TRACE(toString(kind));
        const VolumeGrid a = makeVolume(smallElement(kind, 9)), b = makeVolume(smallElement(kind, 9));
        const VolumeGrid c = makeVolume(smallElement(kind, 10));
        EXPECT_EQ(a.activeVoxelCount(), b.activeVoxelCount());
        EXPECT_EQ(a.meanValue(), b.meanValue());
        EXPECT_EQ(a.boundsMinMm(), b.boundsMinMm());
        VolumeGrid::Sampler sa = a.sampler(), sb = b.sampler(), sc = c.sampler();
        Rng rng(1, 2);
        int differ = 0;
        for (int n = 0; n < kLookups; ++n) {
            const glm::dvec3 p = randomPoint(rng, {-3.0, -3.0, 0.0}, {3.0, 3.0, 1.5});
            ASSERT_EQ(sa.densityAt(p), sb.densityAt(p));
            differ += sa.densityAt(p) != sc.densityAt(p);
        }
        EXPECT_TRUE(differ > 0 || a.meanValue() != c.meanValue() || a.activeVoxelCount() != c.activeVoxelCount());
    }
}

TEST_F(VolumeMakeTest, BadOptionsThrow) {
    VolumeMakeOptions o = smallElement(VolumeMakeOptions::Kind::Haze);
    auto with = [&](auto change) {
        VolumeMakeOptions copy = o;
        change(copy);
        return copy;
    };
    EXPECT_THROW(makeVolume(with([](auto& x) { x.radiusMm = 0.0; })), std::invalid_argument);
    EXPECT_THROW(makeVolume(with([](auto& x) { x.thicknessMm = -1.0; })), std::invalid_argument);
    EXPECT_THROW(makeVolume(with([](auto& x) { x.voxelMm = 2.0; })), std::invalid_argument);  // thicker than 1.5 mm
    EXPECT_THROW(makeVolume(with([](auto& x) { x.voxelMm = 1e-4; })), std::invalid_argument);  // too many voxels
    EXPECT_THROW(makeVolume(with([](auto& x) { x.density = 0.0; })), std::invalid_argument);
    EXPECT_THROW(makeVolume(with([](auto& x) { x.variation = 1.5; })), std::invalid_argument);
    EXPECT_THROW(makeVolume(with([](auto& x) {
                     x.kind = VolumeMakeOptions::Kind::Bubbles;
                     x.count = 0;
                 })),
                 std::invalid_argument);
    EXPECT_EQ(parseVolumeKind("striae"), VolumeMakeOptions::Kind::Striae);
    EXPECT_FALSE(parseVolumeKind("smoke"));
}

// ---- Shipped grids and the CLI ------------------------------------------------------------------------

using test::CliRun;
using test::runCli;

const char* const kShippedVolumes[] = {"volumes/haze.vdb", "volumes/striae.vdb", "volumes/bubbles.vdb",
                                       "volumes/inclusions.vdb"};

TEST_F(VolumeCliTest, ShippedGridsLoadAndAreSmall) {
    for (const char* relative : kShippedVolumes) {
        SCOPED_TRACE(relative);
        const std::string file = test::sourcePath(relative);
        EXPECT_LT(fs::file_size(file), 2u * 1024u * 1024u);
        const VolumeGrid grid = VolumeGrid::load(file);
        EXPECT_GT(grid.activeVoxelCount(), 0u);
        EXPECT_NE(grid.description().find("flare volume make"), std::string::npos);
        for (int c = 0; c < 2; ++c) {
            EXPECT_GE(grid.boundsMinMm()[c], -12.0 - 1e-9);
            EXPECT_LE(grid.boundsMaxMm()[c], 12.0 + 1e-9);
        }
        EXPECT_GE(grid.boundsMinMm().z, -1e-9);
        EXPECT_LE(grid.boundsMaxMm().z, 6.0 + 1e-9);
    }
}

TEST_F(VolumeCliTest, InfoPrintsBoundsVoxelAndValues) {
    const std::string file = test::sourcePath("volumes/haze.vdb");
    const CliRun text = runCli("volume info " + file);
    ASSERT_EQ(text.exitCode, 0) << text.out;
    for (const char* key : {"bounds", "voxel size", "values", "active voxels", "density"})
        EXPECT_NE(text.out.find(key), std::string::npos) << key << "\n" << text.out;

    const CliRun json = runCli("volume info " + file + " --json");
    ASSERT_EQ(json.exitCode, 0) << json.out;
    const nlohmann::json j = nlohmann::json::parse(json.out);
    const VolumeGrid grid = VolumeGrid::load(file);
    EXPECT_EQ(j["grid"], grid.name());
    EXPECT_DOUBLE_EQ(j["voxel_size_mm"].get<double>(), grid.voxelSizeMm());
    EXPECT_DOUBLE_EQ(j["max_value"].get<double>(), grid.maxValue());
    EXPECT_EQ(j["active_voxels"].get<std::size_t>(), grid.activeVoxelCount());
    for (int c = 0; c < 3; ++c) {
        EXPECT_DOUBLE_EQ(j["bounds_min_mm"][c].get<double>(), grid.boundsMinMm()[c]);
        EXPECT_DOUBLE_EQ(j["bounds_max_mm"][c].get<double>(), grid.boundsMaxMm()[c]);
    }
    EXPECT_TRUE(j["grids"].is_array());
}

TEST_F(VolumeCliTest, MakeWritesALoadableGrid) {
    const std::string file = path("made.vdb");
    const CliRun r = runCli("volume make --kind bubbles --radius 3 --thickness 1.5 --voxel 0.1 --seed 4 --count 7 "
                            "--feature 0.2 --density 2 -o " + file);
    ASSERT_EQ(r.exitCode, 0) << r.out;
    EXPECT_NE(r.out.find("wrote"), std::string::npos);
    EXPECT_FALSE(fs::exists(file + ".partial"));
    const VolumeGrid grid = VolumeGrid::load(file);
    EXPECT_LE(grid.maxValue(), 2.0);
    EXPECT_NE(grid.description().find("--count 7"), std::string::npos) << grid.description();

    // The same as the library with the same options.
    VolumeMakeOptions o;
    o.kind = VolumeMakeOptions::Kind::Bubbles;
    o.radiusMm = 3.0;
    o.thicknessMm = 1.5;
    o.voxelMm = 0.1;
    o.seed = 4;
    o.count = 7;
    o.featureMm = 0.2;
    o.density = 2.0;
    const VolumeGrid library = makeVolume(o);
    EXPECT_EQ(grid.activeVoxelCount(), library.activeVoxelCount());
    EXPECT_EQ(grid.meanValue(), library.meanValue());
}

TEST_F(VolumeCliTest, BadInputExitsWithCode2AndWritesNothing) {
    const std::string missing = path("missing.vdb");
    CliRun r = runCli("volume info " + missing);
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find(missing), std::string::npos) << r.out;

    const std::string garbage = path("garbage.vdb");
    std::ofstream(garbage) << "not a grid";
    r = runCli("volume info " + garbage);
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find(garbage), std::string::npos) << r.out;

    r = runCli("volume info " + test::sourcePath("volumes/haze.vdb") + " --grid nosuchgrid");
    EXPECT_EQ(r.exitCode, 2) << r.out;
    EXPECT_NE(r.out.find("nosuchgrid"), std::string::npos) << r.out;

    openvdb::Vec3SGrid::Ptr vec = openvdb::Vec3SGrid::create();
    vec->setName("density");
    vec->tree().setValue(openvdb::Coord(0), openvdb::Vec3f(1.0f));
    const std::string vecFile = writeVdb("vec3.vdb", {vec});
    r = runCli("volume info " + vecFile);
    EXPECT_EQ(r.exitCode, 2) << r.out;

    const std::string out = path("never.vdb");
    EXPECT_EQ(runCli("volume make --kind haze --thickness 1 --voxel 2 -o " + out).exitCode, 2);  // voxel too thick
    EXPECT_EQ(runCli("volume make --kind smoke -o " + out).exitCode, 2);
    EXPECT_EQ(runCli("volume make --kind haze --voxel -1 -o " + out).exitCode, 2);
    EXPECT_EQ(runCli("volume make --kind haze").exitCode, 2);  // no output
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(out + ".partial"));
}

// A grid name that is not UTF-8 (bytes from the file): --json replaces them (U+FFFD) instead of
// failing with exit code 1.
TEST_F(VolumeCliTest, GridNameThatIsNotUtf8DoesNotBreakJson) {
    const std::string file = writeVdb("name.vdb", {floatGrid("dens\xffity", 1.0f)});
    const CliRun r = runCli("volume info " + file + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.out;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["grid"], "dens\xef\xbf\xbdity");
    EXPECT_EQ(j["grids"][0]["name"], "dens\xef\xbf\xbdity");
}

// Issue 33: the file of the fuzz campaign aborted `flare volume info` with heap corruption
// ("malloc(): corrupted top size"). Now exit 2, naming the file and what is wrong with it.
TEST_F(VolumeCliTest, FileWithDuplicatedBytesExitsWithCode2) {
    const std::string file = inclusionsWithDuplicatedBytes(path("duplicated.vdb"));
    for (const std::string options : {"", " --json"}) {
        const CliRun r = runCli("volume info " + file + options);
        EXPECT_EQ(r.exitCode, 2) << r.out;
        EXPECT_NE(r.out.find("flare: error: " + file + ": grid \"density\""), std::string::npos) << r.out;
        EXPECT_EQ(r.out.find("malloc"), std::string::npos) << r.out;
        EXPECT_EQ(r.out.find("Sanitizer"), std::string::npos) << r.out;
    }
}

}  // namespace
}  // namespace flare
