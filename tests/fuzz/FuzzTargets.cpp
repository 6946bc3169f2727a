#include "FuzzTargets.h"
#include "FuzzTextSeeds.h"

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <sys/mman.h>
#include <unistd.h>

#include <Imath/ImathBox.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfRgbaFile.h>
#include <OpenEXR/ImfTiledRgbaFile.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include "flare/core/Error.h"
#include "flare/core/Random.h"
#include "flare/core/TextEncoding.h"
#include "flare/film/Film.h"
#include "flare/film/ImageIO.h"
#include "flare/optics/AgfCatalog.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/PbrtLensFile.h"
#include "flare/optics/SequentialTracer.h"
#include "flare/optics/ZemaxFile.h"
#include "flare/photons/PhotonTracer.h"
#include "flare/photons/VolumeGrid.h"
#include "flare/render/Render.h"
#include "flare/scene/Scene.h"

namespace flare::fuzz {

namespace {

// Keeps the optimiser from dropping reads whose only purpose is to let ASan check them.
volatile double gSink = 0.0;
// Inputs a loader accepted (acceptedInputCount).
std::atomic<long> gAccepted{0};

// The file the loaders read an input from (they take paths): an anonymous file in memory
// (memfd_create), named by /proc/self/fd/N, rewritten for every input and gone with the process,
// so a replay in the suite leaves nothing behind. It was a file in $TMPDIR: on ext4 (this VM's
// /tmp) truncating a file that holds data and writing it again makes the close start its
// writeback (ext4's auto_da_alloc, meant for replace-via-truncate), so every input waited for the
// disk, and while other jobs wrote too the vdb target ran 150-200 inputs/s with 0.8 s of CPU in
// 12 s (2 000 inputs; on tmpfs the same run took 2.7 s). A memory file never reaches a disk,
// whatever filesystem TMPDIR is on.
class MemoryFile {
public:
    explicit MemoryFile(const char* name) : fd_(::memfd_create(name, MFD_CLOEXEC)) {
        if (fd_ < 0) throw std::runtime_error(std::string("memfd_create: ") + std::strerror(errno));
        path_ = "/proc/self/fd/" + std::to_string(fd_);
    }
    ~MemoryFile() { ::close(fd_); }
    MemoryFile(const MemoryFile&) = delete;
    MemoryFile& operator=(const MemoryFile&) = delete;
    const std::string& path() const { return path_; }

    // Replaces the content by data (the loaders open the path afresh, at offset 0).
    void write(std::string_view data) const {
        if (::ftruncate(fd_, 0) != 0) throw std::runtime_error(std::string("ftruncate: ") + std::strerror(errno));
        size_t done = 0;
        while (done < data.size()) {
            const ssize_t n = ::pwrite(fd_, data.data() + done, data.size() - done, static_cast<off_t>(done));
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) throw std::runtime_error(std::string("pwrite: ") + std::strerror(errno));
            done += static_cast<size_t>(n);
        }
    }

private:
    int fd_;
    std::string path_;
};

// A parsed lens is built and traced a little: the parser's job is to let through only lenses the
// rest of the engine can handle.
void exercise(const LensPrescription& prescription) {
    const LensSystem lens = LensSystem::build(prescription);
    const ParaxialData paraxial = analyseParaxial(lens, 550.0);
    gSink = gSink + paraxial.eflMm;
    const SpectralIndices indices = lens.indicesAt(550.0);
    const double front = lens.surface(0).semiApertureMm;
    const double zStart = lens.surface(0).vertexZMm - 100.0;
    for (int i = 0; i < 3; ++i) {
        const Ray ray{{0.0, 0.5 * i * front, zStart}, {0.0, 0.0, 1.0}};
        gSink = gSink + traceForward(lens, indices, ray).throughput;
    }
    const PhotonTracer tracer(lens, InteriorMaterials{0.5, 0.5, 0.5});
    Rng rng(1, 2);
    PhotonHistory history;
    for (int i = 0; i < 8; ++i) {
        const Ray ray{{front * (rng.uniform() - 0.5), front * (rng.uniform() - 0.5), zStart}, {0.0, 0.0, 1.0}};
        tracer.trace(indices, ray, rng, history);
        gSink = gSink + history.arrivalCount;
    }
}

// ---- The checkpoint fixture: a small render whose checkpoints the target loads. ------------------

constexpr std::string_view kCheckpointScene = R"({
  "lens": "double-gauss-50mm",
  "f_number": 4.0,
  "sensor": { "resolution": [33, 22] },
  "lights": [ { "type": "directional", "field_deg": [6.0, 4.0], "angular_diameter_deg": 0.53 } ]
})";

struct CheckpointFixture {
    Scene scene;
    LensSystem lens;
    RenderOptions options;
    std::unique_ptr<Renderer> renderer;

    CheckpointFixture()
        : scene(parseSceneText(kCheckpointScene, "fuzz-checkpoint.json", "")), lens(buildSceneLens(scene)) {
        options.seed = 5;
        options.film.widthPx = scene.sensor.widthPx;
        options.film.heightPx = scene.sensor.heightPx;
        options.film.widthMm = lens.sensor().widthMm;
        options.film.heightMm = lens.sensor().heightMm;
        options.film.kernel = FilmSettings::Kernel::Adaptive;  // its count grid is in the checkpoint too
        // As small as still uses every part of a checkpoint. The film is most of its bytes, and
        // libFuzzer hashes (SHA-1) and copies every input: at 36 x 24 pixels and two batches of 64
        // photons a pass, a checkpoint was 490 kB, its hash 11 % of the target's time and the pass
        // after each load (those photons and 1024 beams) another 20 %. The film keeps its pixels in
        // tiles of 32 x 32, written whole when a photon touched them: 33 x 22 pixels (the frame's
        // 3:2) are still two tiles wide, so the loader still walks a row of tiles, present and
        // absent, but the second is one pixel wide and rarely touched. One batch of 32 photons
        // and a few beams a pass still reach the guided photons, the beams and the unguided tracer.
        options.batchPhotons = 32;
        options.batchesPerPass = 1;
        options.beamsPerPass = 8;
        renderer = std::make_unique<Renderer>(lens, scene.lights, options);
    }
};

CheckpointFixture& checkpointFixture() {
    static CheckpointFixture fixture;
    return fixture;
}

void touch(const std::vector<float>& values) {
    double sum = 0.0;
    for (float v : values) sum += v;
    gSink = gSink + sum;
}

}  // namespace

void lensInput(std::string_view data) {
    try {
        exercise(parseLensText(data, "fuzz.lens"));
    } catch (const InputError&) {
    }
    try {
        exercise(parsePbrtLensText(data, "fuzz.dat"));
    } catch (const InputError&) {
    }
    try {
        std::vector<std::string> warnings;  // kept off stderr
        exercise(parseZemaxText(data, "fuzz.zmx", &warnings));
    } catch (const InputError&) {
    }
}

void zmxInput(std::string_view data) {
    try {
        std::vector<std::string> warnings;  // kept off stderr
        exercise(parseZemaxText(data, "fuzz.zmx", &warnings));
    } catch (const InputError&) {
    }
}

namespace {
// The singlet agfInput puts a fuzzed glass into (its front element's medium is replaced).
const LensPrescription& agfSinglet() {
    static const LensPrescription singlet = parseLensText(R"(name agf fuzz singlet
focal_length_mm 50
surfaces
  50     4     N-BK7   10
  -50    2     air     10
  stop   auto  air     8
)",
                                                          "agf-singlet.lens");
    return singlet;
}
}  // namespace

void agfInput(std::string_view data) {
    try {
        const AgfCatalog catalog = AgfCatalog::parse(decodeText(data, "fuzz.agf"), "fuzz.agf", "FUZZ");
        int traced = 0;
        for (const AgfGlass& g : catalog.glasses()) {
            // What a lens asks of a glass: indices across the visible (and beyond, where a
            // formula may have poles), the catalogue's lookup, and for a glass made for the
            // visible, a lens built and traced with it.
            for (double nm = 300.0; nm <= 900.0; nm += 25.0) gSink = gSink + catalogIndex(g.glass, nm);
            gSink = gSink + static_cast<double>(validRangeText(g.glass).size());
            if (catalog.find(g.glass.name) == nullptr) throw std::logic_error("a parsed glass is not found by its name");
            if (!coversVisible(g.glass) || traced >= 4) continue;
            LensPrescription singlet = agfSinglet();
            singlet.rows[0].mediumAfter = Medium::catalog(g.glass);
            exercise(singlet);
            ++traced;
        }
    } catch (const InputError&) {
    }
}

void sceneInput(std::string_view data) {
    try {
        // Relative lens paths resolve against a folder that does not exist: only shipped lens
        // names (and absolute paths, which are not read) get through.
        const Scene scene = parseSceneText(data, "fuzz.json", "/nonexistent-flare-fuzz-dir");
        if (scene.lens.find('/') != std::string::npos) return;
        const LensSystem lens = buildSceneLens(scene);
        const glm::dvec2 size = sensorSizeMm(scene, lens.sensor());
        gSink = gSink + size.x + size.y;
        for (const LightSpec& light : scene.lights) gSink = gSink + light.travelDirection().z;
    } catch (const InputError&) {
    }
}

namespace {
// True if a header of an EXR declares an attribute longer than the whole file. OpenEXR 3.1
// allocates a declared attribute size (up to 2 GB) and fills it (a string attribute is resized
// first) before finding the file too short; that is the library's behaviour, costs little without
// ASan, but under ASan every such input takes ~50 ms, which starved the fuzzer (25 inputs/s).
// Such inputs are skipped; tests/data/fuzz/exr/huge-unknown-attribute.exr is one of them, kept for
// the record. Every header is walked: a multi-part file (version flag 0x1000) holds one per part,
// each ended by a NUL, the list ended by an empty header.
bool declaresAttributeLongerThanFile(std::string_view data) {
    if (data.size() < 8) return false;
    std::uint32_t version = 0;
    std::memcpy(&version, data.data() + 4, 4);
    const bool multipart = (version & 0x1000u) != 0;
    size_t i = 8;  // magic number and version
    while (i < data.size()) {
        if (data[i] == '\0') {  // the end of a header
            if (!multipart) return false;
            ++i;
            if (i >= data.size() || data[i] == '\0') return false;  // the empty header ends the list
            continue;
        }
        for (int field = 0; field < 2; ++field) {  // name and type, NUL-terminated
            const size_t end = data.find('\0', i);
            if (end == std::string_view::npos) return false;
            i = end + 1;
        }
        if (i + 4 > data.size()) return false;
        std::int32_t size = 0;
        std::memcpy(&size, data.data() + i, 4);
        if (size < 0 || static_cast<size_t>(size) > data.size()) return true;
        i += 4 + static_cast<size_t>(size);
    }
    return false;
}

// True if a header of the input declares a data or display window, or tiles, of more than
// kMaxFuzzedPixels pixels, or more chunks than that. readExr allocates and zeroes a float buffer
// the size of the data window (and of the frame), and OpenEXR its offset table (one entry per
// chunk) and its line or tile buffers, before the pixels
// are read; a mutated corner or tile size makes those megabytes to gigabytes, which under ASan cost
// milliseconds of page faults and unmapping each: 23 inputs/s, four fifths of it system time, in a
// campaign of 27 November 2026. A fuzzed file of at most 4 kB cannot hold more than about 4 MB of
// pixels (zip, the strongest of its codecs, compresses at most ~1000:1), so such inputs only repeat
// the allocation; the refusal of windows beyond readExr's own limit is tested without the fuzzer
// (ImageIOTest.WindowBeyondTheFrameLimitIsRefused).
constexpr long long kMaxFuzzedPixels = 1LL << 16;

bool declaresLargeWindow(std::string_view data) {
    // In double: the sides are up to 2^32 each, their product beyond 64-bit integers.
    const auto area = [](double width, double height) { return width > 0 && height > 0 ? width * height : 0.0; };
    const auto each = [&](std::string_view attribute, size_t bytes, auto tooLarge) {
        for (size_t at = data.find(attribute); at != std::string_view::npos; at = data.find(attribute, at + 1)) {
            const size_t value = at + attribute.size() + 4;  // after the attribute's 4-byte size
            if (value + bytes > data.size()) break;
            std::int32_t v[4] = {};
            std::memcpy(v, data.data() + value, bytes);
            if (tooLarge(v)) return true;
        }
        return false;
    };
    const auto boxTooLarge = [&](const std::int32_t* v) {
        return area(static_cast<double>(v[2]) - v[0] + 1, static_cast<double>(v[3]) - v[1] + 1) > kMaxFuzzedPixels;
    };
    const auto tilesTooLarge = [&](const std::int32_t* v) {
        return area(static_cast<std::uint32_t>(v[0]), static_cast<std::uint32_t>(v[1])) > kMaxFuzzedPixels;
    };
    return each(std::string_view("dataWindow\0box2i\0", 17), 16, boxTooLarge) ||
           each(std::string_view("displayWindow\0box2i\0", 20), 16, boxTooLarge) ||
           each(std::string_view("tiles\0tiledesc\0", 15), 8, tilesTooLarge) ||
           each(std::string_view("chunkCount\0int\0", 15), 4, [](const std::int32_t* v) { return v[0] > kMaxFuzzedPixels; });
}
}  // namespace

long acceptedInputCount() { return gAccepted.load(); }

void exrInput(std::string_view data) {
    if (declaresAttributeLongerThanFile(data) || declaresLargeWindow(data)) return;
    static const MemoryFile file("fuzz.exr");
    const std::string& path = file.path();
    file.write(data);
    try {
        for (const ImageLayer& layer : readExr(path)) touch(layer.rgb);
        ++gAccepted;
    } catch (const InputError&) {
    }
}

void vdbInput(std::string_view data) {
    static const MemoryFile file("fuzz.vdb");
    const std::string& path = file.path();
    file.write(data);
    VolumeGrid grid;
    try {
        grid = VolumeGrid::load(path);
    } catch (const InputError&) {
        return;
    }
    ++gAccepted;
    // A loaded grid must be usable as a scene's volume: its statistics, its active boxes (the
    // majorant grid's input) and lookups inside, at the edges of and outside its bounds.
    const glm::dvec3 lo = grid.boundsMinMm(), hi = grid.boundsMaxMm();
    gSink = gSink + grid.voxelSizeMm() + grid.minValue() + grid.maxValue() + grid.meanValue() +
            static_cast<double>(grid.activeVoxelCount()) + static_cast<double>(grid.description().size());
    int boxes = 0;
    grid.forEachActiveBox([&](const glm::dvec3& boxMin, const glm::dvec3& boxMax, double value) {
        if (++boxes <= 64) gSink = gSink + boxMin.x + boxMax.z + value;
    });
    VolumeGrid::Sampler sampler = grid.sampler();
    Rng rng(3, 4);
    for (int i = 0; i < 16; ++i) {
        const glm::dvec3 t{rng.uniform(), rng.uniform(), rng.uniform()};
        gSink = gSink + sampler.densityAt(lo + t * (hi - lo));
    }
    for (const glm::dvec3& p : {lo, hi, 0.5 * (lo + hi), 2.0 * hi - lo, glm::dvec3(0.0)})
        gSink = gSink + sampler.densityAt(p);
}

void checkpointInput(std::string_view data) {
    CheckpointFixture& f = checkpointFixture();
    // (Any version of the film's magic, "FLRFILF" and a digit: Film::load checks the version. The
    // version once was 1 here while the film wrote 6, and every bare film went to loadCheckpoint.)
    if (data.size() >= 8 && std::memcmp(data.data(), "FLRFILF", 7) == 0) {
        // A bare film, as Film::save writes it inside a checkpoint.
        // Shaped as the render's film (Film::load refuses any other shape): its layers (with,
        // under the adaptive pass plan, the hidden beams layer), its variance groups (a group's
        // layers matter to what is added, not to what is loaded) and its replicates.
        const Film& renders = f.renderer->film();
        Film film(renders.settings(), renders.layerCount());
        while (film.varianceGroupCount() < renders.varianceGroupCount()) film.addVarianceGroup({});
        film.setReplicates(renders.replicates());
        std::istringstream in(std::string(data), std::ios::binary);
        try {
            film.load(in);
        } catch (const std::runtime_error&) {
            return;
        }
        ++gAccepted;
        for (int l = 0; l < film.layerCount(); ++l) touch(film.irradianceXyz(l, 1000.0));
        touch(film.varianceRgb());
        return;
    }
    static const MemoryFile file("fuzz.checkpoint");
    const std::string& path = file.path();
    file.write(data);
    try {
        f.renderer->loadCheckpoint(path);
    } catch (const InputError&) {
        return;
    }
    ++gAccepted;
    // A loaded checkpoint must be usable: read every output and continue the render by a pass.
    for (int l = 0; l < static_cast<int>(f.renderer->layerNames().size()); ++l) touch(f.renderer->layerXyz(l));
    touch(f.renderer->film().varianceRgb());
    for (const PathTally& t : f.renderer->tallies()) gSink = gSink + f.renderer->tallyStandardErrorW(t);
    f.renderer->runPass();
}

namespace {
// Small .vdb seeds: the shipped volumes are 40 kB to 600 kB, too large to mutate quickly. Float
// grids as flare writes them (zipped) and unzipped (so that mutations hit values and topology
// directly), and one grid for each way load() rejects a well-formed file.
int writeVdbSeeds(const std::filesystem::path& vdbDir) {
    std::filesystem::create_directories(vdbDir);
    int written = 0;
    // zipped: OpenVDB's default (zip + active mask), as flare saves; else active mask only, which
    // keeps the file small (inactive tile values omitted) but lets mutations reach raw values.
    auto write = [&](const std::string& file, const openvdb::GridPtrVec& grids, bool zipped) {
        openvdb::io::File out((vdbDir / file).string());
        if (!zipped) out.setCompression(openvdb::io::COMPRESS_ACTIVE_MASK);
        out.write(grids);
        out.close();
        ++written;
    };
    auto floatGrid = [](const std::string& name, float value) {
        openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
        g->setName(name);
        g->setTransform(openvdb::math::Transform::createLinearTransform(0.5));
        g->tree().setValue(openvdb::Coord(1, 2, 3), value);
        g->tree().setValue(openvdb::Coord(4, 2, 3), 0.25f);
        return g;
    };

    // Grids are built voxel by voxel here, not with makeVolume: destroying a tree that parallel
    // code has held accessors to trips clang's alignment check inside oneTBB's concurrent_hash_map
    // (a marker pointer cast to node*; library header code), which would stop the seed generator.
    VolumeGrid::constant(0.5, glm::dvec3(-1.0), glm::dvec3(1.0), 0.5).save((vdbDir / "constant-box.vdb").string());
    ++written;
    openvdb::FloatGrid::Ptr speckles = floatGrid("density", 1.0f);
    for (int i = 0; i < 12; ++i) speckles->tree().setValue(openvdb::Coord(3 * i, i % 5, 20 - i), 0.1f * i);
    speckles->insertMeta("description", openvdb::StringMetadata("fuzz seed: a few voxels in two leaves"));
    write("speckles.vdb", {speckles}, true);
    write("two-voxels-unzipped.vdb", {floatGrid("density", 1.0f)}, false);
    write("two-grids.vdb", {floatGrid("smoke", 2.0f), floatGrid("density", 1.0f)}, true);
    openvdb::FloatGrid::Ptr tile = openvdb::FloatGrid::create(0.0f);
    tile->setName("density");
    tile->tree().addTile(1, openvdb::Coord(0), 0.75f, true);  // one active 8³ tile
    write("active-tile-unzipped.vdb", {tile}, false);

    openvdb::Vec3SGrid::Ptr vec = openvdb::Vec3SGrid::create();
    vec->setName("density");
    vec->tree().setValue(openvdb::Coord(0), openvdb::Vec3f(1.0f, 2.0f, 3.0f));
    write("vec3s-grid.vdb", {vec}, false);
    openvdb::Int32Grid::Ptr ints = openvdb::Int32Grid::create(0);
    ints->setName("density");
    ints->tree().setValue(openvdb::Coord(0), 3);
    write("int32-grid.vdb", {ints}, false);
    write("nan-value.vdb", {floatGrid("density", std::nanf(""))}, false);
    write("negative-value.vdb", {floatGrid("density", -0.5f)}, false);
    openvdb::FloatGrid::Ptr none = openvdb::FloatGrid::create(0.0f);
    none->setName("density");
    write("no-active-voxels.vdb", {none}, false);
    write("no-grids.vdb", {}, false);
    openvdb::FloatGrid::Ptr frustum = floatGrid("density", 1.0f);
    frustum->setTransform(openvdb::math::Transform::createFrustumTransform(
        openvdb::BBoxd(openvdb::Vec3d(0.0), openvdb::Vec3d(7.0)), 0.5, 2.0, 0.5));
    write("frustum-transform.vdb", {frustum}, false);
    return written;
}
}  // namespace

int writeGeneratedSeeds(const std::string& dir) {
    int written = 0;
    const std::filesystem::path exrDir = std::filesystem::path(dir) / "exr";
    const std::filesystem::path checkpointDir = std::filesystem::path(dir) / "checkpoint";
    std::filesystem::create_directories(exrDir);
    std::filesystem::create_directories(checkpointDir);

    // Float EXRs as the engine writes them (ZIP, main image and layers).
    auto layer = [](const std::string& name, int w, int h) {
        ImageLayer l{name, w, h, std::vector<float>(3 * static_cast<size_t>(w) * h)};
        for (size_t i = 0; i < l.rgb.size(); ++i) l.rgb[i] = 0.01f * static_cast<float>(i % 97);
        return l;
    };
    writeExr((exrDir / "main-4x3.exr").string(), {layer("", 4, 3)}, {});
    writeExr((exrDir / "layers-8x8.exr").string(), {layer("", 8, 8), layer("ghost", 8, 8), layer("direct", 8, 8)},
             {{"flare:seed", "1"}});
    writeExr((exrDir / "one-pixel.exr").string(), {layer("", 1, 1)}, {});
    // Per-ghost layers as parts of their own over their footprints (a multi-part file).
    ImageLayer footprint = layer("ghost_03_01", 3, 2);
    footprint.x = 4, footprint.y = 5;
    ExrWriteOptions parts;
    parts.ownParts = {"ghost_03_01"};
    writeExr((exrDir / "parts-8x8.exr").string(), {layer("", 8, 8), layer("ghost", 8, 8), footprint}, {}, parts);
    written += 4;

    // Half RGBA through OpenEXR directly: other compressions, an offset data window, tiles, mipmaps.
    const int w = 6, h = 5;
    std::vector<Imf::Rgba> pixels(static_cast<size_t>(w) * h);
    for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = Imf::Rgba(0.1f * (i % 7), 0.2f, 0.3f, 1.0f);
    for (const auto& [name, compression] : {std::pair{"rle", Imf::RLE_COMPRESSION}, std::pair{"piz", Imf::PIZ_COMPRESSION},
                                            std::pair{"none", Imf::NO_COMPRESSION}, std::pair{"b44", Imf::B44_COMPRESSION},
                                            std::pair{"pxr24", Imf::PXR24_COMPRESSION}}) {
        Imf::RgbaOutputFile file((exrDir / ("half-" + std::string(name) + ".exr")).c_str(), w, h, Imf::WRITE_RGB, 1.0f,
                                 Imath::V2f(0.0f, 0.0f), 1.0f, Imf::INCREASING_Y, compression);
        file.setFrameBuffer(pixels.data(), 1, w);
        file.writePixels(h);
        ++written;
    }
    {
        Imf::Header header(Imath::Box2i(Imath::V2i(0, 0), Imath::V2i(9, 9)), Imath::Box2i(Imath::V2i(2, 3), Imath::V2i(7, 7)));
        Imf::RgbaOutputFile file((exrDir / "offset-window.exr").c_str(), header, Imf::WRITE_RGB);
        file.setFrameBuffer(pixels.data() - (2 + 3 * w), 1, w);
        file.writePixels(h);
        ++written;
    }
    {
        // Overscan: the data window starts left of and above the display window.
        Imf::Header header(Imath::Box2i(Imath::V2i(0, 0), Imath::V2i(3, 2)), Imath::Box2i(Imath::V2i(-2, -1), Imath::V2i(3, 3)));
        Imf::RgbaOutputFile file((exrDir / "negative-window.exr").c_str(), header, Imf::WRITE_RGB);
        file.setFrameBuffer(pixels.data() + (2 + 1 * w), 1, w);
        file.writePixels(h);
        ++written;
    }
    for (const auto& [name, mode] : {std::pair{"tiled", Imf::ONE_LEVEL}, std::pair{"mipmap", Imf::MIPMAP_LEVELS}}) {
        Imf::TiledRgbaOutputFile file((exrDir / (std::string(name) + ".exr")).c_str(), w, h, 4, 4, mode, Imf::ROUND_DOWN,
                                      Imf::WRITE_RGB, 1.0f, Imath::V2f(0.0f, 0.0f), 1.0f, Imf::INCREASING_Y,
                                      Imf::ZIP_COMPRESSION);
        file.setFrameBuffer(pixels.data(), 1, w);
        file.writeTiles(0, file.numXTiles(0) - 1, 0, file.numYTiles(0) - 1, 0);
        if (mode == Imf::MIPMAP_LEVELS) {
            for (int level = 1; level < file.numLevels(); ++level) {
                const int lw = file.levelWidth(level), lh = file.levelHeight(level);
                std::vector<Imf::Rgba> small(static_cast<size_t>(lw) * lh, Imf::Rgba(0.5f, 0.5f, 0.5f, 1.0f));
                file.setFrameBuffer(small.data(), 1, lw);
                file.writeTiles(0, file.numXTiles(level) - 1, 0, file.numYTiles(level) - 1, level);
            }
        }
        ++written;
    }

    // A checkpoint of the fixture's render after one pass, and its bare film.
    CheckpointFixture& f = checkpointFixture();
    f.renderer->runPass();
    f.renderer->saveCheckpoint((checkpointDir / "render.checkpoint").string());
    std::ofstream film(checkpointDir / "film.bin", std::ios::binary);
    f.renderer->film().save(film);
    written += 2;

    written += writeVdbSeeds(std::filesystem::path(dir) / "vdb");
    written += writeZmxSeeds(std::filesystem::path(dir) / "zmx");
    written += writeAgfSeeds(std::filesystem::path(dir) / "agf");
    return written;
}

}  // namespace flare::fuzz
