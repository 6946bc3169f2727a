#include "flare/render/PassWire.h"

#include <algorithm>
#include <climits>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "flare/film/Film.h"

namespace flare::renderer {

namespace {

// Records: a tag, the job's index, then the fields in a fixed order, each a trivially copyable
// value or a counted array of them, copied as bytes (the same build at both ends).
constexpr std::uint8_t kBatchTag = 1, kBeamTag = 2, kTraceTimeTag = 3, kBandImageTag = 4, kBandCostsTag = 5;

static_assert(std::is_trivially_copyable_v<SensorHit>);
static_assert(std::is_trivially_copyable_v<BeamTriangle>);
static_assert(std::is_trivially_copyable_v<BeamRim::Segment>);
static_assert(std::is_trivially_copyable_v<RenderStatistics>);

template <class T>
void put(std::vector<char>& out, const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const char* bytes = reinterpret_cast<const char*>(&value);
    out.insert(out.end(), bytes, bytes + sizeof value);
}

template <class T>
void putArray(std::vector<char>& out, const std::vector<T>& values) {
    static_assert(std::is_trivially_copyable_v<T>);
    put(out, static_cast<std::uint64_t>(values.size()));
    const char* bytes = reinterpret_cast<const char*>(values.data());
    out.insert(out.end(), bytes, bytes + values.size() * sizeof(T));
}

class Reader {
public:
    explicit Reader(const std::vector<char>& message) : message_(message) {}
    bool done() const { return at_ == message_.size(); }

    template <class T>
    T get() {
        static_assert(std::is_trivially_copyable_v<T>);
        T value;
        need(sizeof value);
        std::memcpy(&value, message_.data() + at_, sizeof value);
        at_ += sizeof value;
        return value;
    }
    // An array of fixed size (a C array member), in place.
    template <class T>
    void getInto(T& value) {
        static_assert(std::is_trivially_copyable_v<T>);
        need(sizeof value);
        std::memcpy(&value, message_.data() + at_, sizeof value);
        at_ += sizeof value;
    }
    size_t left() const { return message_.size() - at_; }
    size_t at() const { return at_; }
    void getBytes(char* to, size_t bytes) {
        need(bytes);
        std::memcpy(to, message_.data() + at_, bytes);
        at_ += bytes;
    }
    void skip(size_t bytes) {
        need(bytes);
        at_ += bytes;
    }
    template <class T>
    std::vector<T> getArray() {
        const auto count = get<std::uint64_t>();
        if (count > (message_.size() - at_) / sizeof(T)) fail("an array runs past the message's end");
        std::vector<T> values(count);
        // An empty vector's data() may be null, which memcpy must not be given even for 0 bytes.
        if (count > 0) std::memcpy(values.data(), message_.data() + at_, count * sizeof(T));
        at_ += count * sizeof(T);
        return values;
    }
    [[noreturn]] void fail(const std::string& why) const {
        throw std::runtime_error("distributed render: a rank's pass results are corrupt (" + why + " at byte " +
                                 std::to_string(at_) + " of " + std::to_string(message_.size()) + ")");
    }

private:
    void need(size_t bytes) const {
        if (message_.size() - at_ < bytes) fail("truncated");
    }
    const std::vector<char>& message_;
    size_t at_ = 0;
};

// A triangle as the merge reads it (GhostBeam::rasterise): its index in the beam (which seeds a
// small triangle's points), its image's corners, and the corners' irradiance, or for a small
// triangle (splatted at points) the corners' throughput and its pupil area. The pupil points and
// the rest serve the trace alone (the mesh, the twins, the rim's construction), which the tracing
// rank has done: 77 or 85 bytes where the whole is 168.
constexpr std::uint8_t kSmallTriangle = 1;

void putTriangles(std::vector<char>& out, const GhostBeam& beam, const std::vector<std::uint32_t>& which) {
    put(out, static_cast<std::uint64_t>(which.size()));
    for (const std::uint32_t n : which) {
        const BeamTriangle& t = beam.triangles()[n];
        put(out, beam.seedIndex(n));
        put(out, static_cast<std::uint8_t>(t.small ? kSmallTriangle : 0));
        put(out, t.pixel);
        if (t.small) {
            put(out, t.throughput);
            put(out, t.pupilAreaMm2);
        } else {
            put(out, t.irradiance);
        }
    }
}

std::vector<BeamTriangle> getTriangles(Reader& in, std::vector<std::uint32_t>& seedIndices) {
    const auto count = in.get<std::uint64_t>();
    if (count > in.left() / (sizeof(std::uint32_t) + 1 + sizeof(BeamTriangle::pixel) + sizeof(BeamTriangle::irradiance)))
        in.fail("a beam's triangles run past the message's end");
    std::vector<BeamTriangle> triangles(count);  // (the fields the merge does not read stay zero)
    seedIndices.resize(count);
    for (size_t n = 0; n < count; ++n) {
        BeamTriangle& t = triangles[n];
        seedIndices[n] = in.get<std::uint32_t>();
        const auto kind = in.get<std::uint8_t>();
        if (kind != 0 && kind != kSmallTriangle) in.fail("a triangle of an unknown kind");
        t.small = kind == kSmallTriangle;
        in.getInto(t.pixel);
        if (t.small) {
            in.getInto(t.throughput);
            t.pupilAreaMm2 = in.get<double>();
        } else {
            in.getInto(t.irradiance);
        }
    }
    return triangles;
}

// A band image's runs: Film's tiles are kBandRows pixels wide, and Film::addBand skips a tile's
// run of a row that holds zeros only.
constexpr int kRunPx = Film::kBandRows;

int rowsOfBand(int band, int heightPx) { return std::min(Film::kBandRows, heightPx - band * Film::kBandRows); }

}  // namespace

void writeBatch(std::int64_t index, const BatchResult& batch, std::vector<char>& out) {
    put(out, kBatchTag);
    put(out, index);
    putArray(out, batch.hits);
    putArray(out, batch.tallySums);
    put(out, batch.layerSums);
    put(out, batch.sourceSums);
    put(out, batch.statistics);
}

void writeBeam(std::int64_t index, const BeamJob& job, std::vector<char>& out) {
    writeBeam(index, job, 0, INT_MAX, true, out);
}

void writeBeam(std::int64_t index, const BeamJob& job, int firstBand, int lastBand, bool withResults,
               std::vector<char>& out) {
    const std::vector<std::uint32_t> triangles = job.beam.trianglesReaching(firstBand, lastBand);
    const std::vector<std::uint32_t> segments = job.beam.rim().segmentsReaching(firstBand, lastBand);
    if (!withResults && triangles.empty() && segments.empty()) return;
    put(out, kBeamTag);
    put(out, index);
    put(out, static_cast<std::uint8_t>(withResults ? 1 : 0));
    putTriangles(out, job.beam, triangles);
    // The rim as built (its Fresnel scale, 0: geometric, and its segments).
    put(out, job.beam.rim().edgeScalePx());
    put(out, static_cast<std::uint64_t>(segments.size()));
    for (const std::uint32_t n : segments) put(out, job.beam.rim().segments()[n]);
    put(out, job.jitterPx);
    put(out, job.scale);
    put(out, job.seed);
    if (!withResults) return;
    put(out, job.beam.tracedRays());
    putArray(out, job.hits);
    put(out, job.powerY);
    put(out, job.photons);
}

void writeBandImage(int band, int layer, bool inTotal, const double* rows, int widthPx, int heightPx, int xBegin,
                    int xEnd, std::vector<char>& out) {
    put(out, kBandImageTag);
    put(out, static_cast<std::int32_t>(band));
    put(out, static_cast<std::int32_t>(layer));
    put(out, static_cast<std::uint8_t>(inTotal ? 1 : 0));
    const size_t countAt = out.size();
    put(out, std::uint32_t{0});
    std::uint32_t runs = 0;
    for (int y = 0; y < rowsOfBand(band, heightPx); ++y)
        for (int x0 = std::max(0, xBegin) / kRunPx * kRunPx; x0 < std::min(widthPx, xEnd); x0 += kRunPx) {
            const double* v = rows + (static_cast<size_t>(y) * widthPx + x0) * 3;
            const int values = std::min(kRunPx, widthPx - x0) * 3;
            if (std::all_of(v, v + values, [](double value) { return value == 0.0; })) continue;
            put(out, static_cast<std::uint32_t>(y));
            put(out, static_cast<std::uint32_t>(x0));
            const char* bytes = reinterpret_cast<const char*>(v);
            out.insert(out.end(), bytes, bytes + values * sizeof(double));
            ++runs;
        }
    std::memcpy(out.data() + countAt, &runs, sizeof runs);
}

void writeBandCosts(int firstBand, const std::vector<double>& seconds, double phaseS, double phaseCpuS,
                    std::vector<char>& out) {
    put(out, kBandCostsTag);
    put(out, static_cast<std::int32_t>(firstBand));
    putArray(out, seconds);
    put(out, phaseS);
    put(out, phaseCpuS);
}

namespace {

// Reads (or, with rows null, checks and skips) a band image's runs.
void readRuns(Reader& in, int band, int widthPx, int heightPx, double* rows) {
    const auto runs = in.get<std::uint32_t>();
    for (std::uint32_t r = 0; r < runs; ++r) {
        const auto y = in.get<std::uint32_t>(), x0 = in.get<std::uint32_t>();
        if (y >= static_cast<std::uint32_t>(rowsOfBand(band, heightPx)) || x0 >= static_cast<std::uint32_t>(widthPx) ||
            x0 % kRunPx != 0)
            in.fail("a band image's run out of range");
        const size_t bytes = static_cast<size_t>(std::min<std::uint32_t>(kRunPx, widthPx - x0)) * 3 * sizeof(double);
        if (rows != nullptr) {
            in.getBytes(reinterpret_cast<char*>(rows + (static_cast<size_t>(y) * widthPx + x0) * 3), bytes);
        } else {
            in.skip(bytes);
        }
    }
}

}  // namespace

BandMessage readBandMessage(const std::vector<char>& message, int widthPx, int heightPx) {
    const int bands = (heightPx + Film::kBandRows - 1) / Film::kBandRows;
    Reader in(message);
    BandMessage read;
    while (!in.done()) {
        const auto tag = in.get<std::uint8_t>();
        if (tag == kBandCostsTag) {
            read.firstBand = in.get<std::int32_t>();
            read.bandSeconds = in.getArray<double>();
            read.phaseS = in.get<double>();
            read.phaseCpuS = in.get<double>();
            if (read.firstBand < 0 || read.firstBand + static_cast<long>(read.bandSeconds.size()) > bands)
                in.fail("band costs out of range");
            continue;
        }
        if (tag != kBandImageTag) in.fail("an unknown record");
        BandImage image;
        image.band = in.get<std::int32_t>();
        image.layer = in.get<std::int32_t>();
        image.inTotal = in.get<std::uint8_t>() != 0;
        if (image.band < 0 || image.band >= bands || image.layer < 0) in.fail("a band image out of range");
        image.at = in.at();
        readRuns(in, image.band, widthPx, heightPx, nullptr);
        read.images.push_back(image);
    }
    return read;
}

void readBandImage(const std::vector<char>& message, const BandImage& image, int widthPx, int heightPx,
                   std::vector<double>& rows) {
    rows.assign(static_cast<size_t>(Film::kBandRows) * widthPx * 3, 0.0);
    Reader in(message);
    in.skip(image.at);
    readRuns(in, image.band, widthPx, heightPx, rows.data());
}

void forEachBandImageRun(const std::vector<char>& message, const BandImage& image, int widthPx, int heightPx,
                         const BandRunAdder& add) {
    Reader in(message);
    in.skip(image.at);
    // (Each run copied out: the message's doubles are not aligned.)
    double values[kRunPx * 3];
    const auto runs = in.get<std::uint32_t>();
    for (std::uint32_t r = 0; r < runs; ++r) {
        const auto y = in.get<std::uint32_t>(), x0 = in.get<std::uint32_t>();
        if (y >= static_cast<std::uint32_t>(rowsOfBand(image.band, heightPx)) ||
            x0 >= static_cast<std::uint32_t>(widthPx) || x0 % kRunPx != 0)
            in.fail("a band image's run out of range");
        const int pixels = std::min<int>(kRunPx, widthPx - static_cast<int>(x0));
        in.getBytes(reinterpret_cast<char*>(values), static_cast<size_t>(pixels) * 3 * sizeof(double));
        add(image.band * Film::kBandRows + static_cast<int>(y), static_cast<int>(x0), static_cast<int>(x0) + pixels, values);
    }
}

void writeTraceTime(double seconds, double cpuSeconds, std::vector<char>& out) {
    put(out, kTraceTimeTag);
    put(out, seconds);
    put(out, cpuSeconds);
}

PassMessage readPassResults(const std::vector<char>& message, const FilmFrame& frame, std::vector<BatchResult>& batches,
                            std::vector<BeamJob>& beams) {
    Reader in(message);
    PassMessage read;
    while (!in.done()) {
        const auto tag = in.get<std::uint8_t>();
        if (tag == kTraceTimeTag) {
            read.traceS = in.get<double>();
            read.traceCpuS = in.get<double>();
            continue;
        }
        const auto index = in.get<std::int64_t>();
        if (tag == kBatchTag) {
            if (index < 0 || index >= static_cast<std::int64_t>(batches.size())) in.fail("a batch index out of range");
            BatchResult& batch = batches[static_cast<size_t>(index)];
            batch.hits = in.getArray<SensorHit>();
            batch.tallySums = in.getArray<double>();
            std::memcpy(batch.layerSums, in.get<std::array<double, kFixedLayerCount>>().data(), sizeof batch.layerSums);
            std::memcpy(batch.sourceSums, in.get<std::array<double, kScatterSources>>().data(), sizeof batch.sourceSums);
            batch.statistics = in.get<RenderStatistics>();
        } else if (tag == kBeamTag) {
            if (index < 0 || index >= static_cast<std::int64_t>(beams.size())) in.fail("a beam index out of range");
            BeamJob& job = beams[static_cast<size_t>(index)];
            const bool withResults = in.get<std::uint8_t>() != 0;
            std::vector<std::uint32_t> seedIndices;
            std::vector<BeamTriangle> triangles = getTriangles(in, seedIndices);
            const double edgeScalePx = in.get<double>();
            if (!(edgeScalePx >= 0.0 && edgeScalePx < 1e9)) in.fail("a rim's Fresnel scale out of range");
            std::vector<BeamRim::Segment> segments = in.getArray<BeamRim::Segment>();
            if (!segments.empty() && !(edgeScalePx > 0.0)) in.fail("a geometric rim with segments");
            job.jitterPx = in.get<glm::dvec2>();
            job.scale = in.get<glm::dvec3>();
            job.seed = in.get<std::uint64_t>();
            const long tracedRays = withResults ? in.get<long>() : 0;
            job.beam = GhostBeam::fromTriangles(std::move(triangles), frame, tracedRays, std::move(seedIndices));
            if (edgeScalePx > 0.0) job.beam.ring(BeamRim::fromSegments(std::move(segments), edgeScalePx, frame.heightPx));
            if (withResults) {
                job.hits = in.getArray<SensorHit>();
                job.powerY = in.get<double>();
                job.photons = in.get<std::int64_t>();
            }
        } else {
            in.fail("an unknown record");
        }
        ++read.jobs;
    }
    return read;
}

}  // namespace flare::renderer
