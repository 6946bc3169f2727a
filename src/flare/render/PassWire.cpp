#include "flare/render/PassWire.h"

#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace flare::renderer {

namespace {

// Records: a tag, the job's index, then the fields in a fixed order, each a trivially copyable
// value or a counted array of them, copied as bytes (the same build at both ends).
constexpr std::uint8_t kBatchTag = 1, kBeamTag = 2, kTraceTimeTag = 3;

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

// A triangle as the merge reads it (GhostBeam::rasterise): its image's corners, and the corners'
// irradiance, or for a small triangle (splatted at points) the corners' throughput and its pupil
// area. The pupil points and the rest serve the trace alone (the mesh, the twins, the rim's
// construction), which the tracing rank has done: 73 or 81 bytes where the whole is 168.
constexpr std::uint8_t kSmallTriangle = 1;

void putTriangles(std::vector<char>& out, const std::vector<BeamTriangle>& triangles) {
    put(out, static_cast<std::uint64_t>(triangles.size()));
    for (const BeamTriangle& t : triangles) {
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

std::vector<BeamTriangle> getTriangles(Reader& in) {
    const auto count = in.get<std::uint64_t>();
    if (count > in.left() / (1 + sizeof(BeamTriangle::pixel) + sizeof(BeamTriangle::irradiance)))
        in.fail("a beam's triangles run past the message's end");
    std::vector<BeamTriangle> triangles(count);  // (the fields the merge does not read stay zero)
    for (BeamTriangle& t : triangles) {
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
    put(out, kBeamTag);
    put(out, index);
    putTriangles(out, job.beam.triangles());
    put(out, job.beam.tracedRays());
    // The rim as built (its Fresnel scale, 0: geometric, and its segments).
    put(out, job.beam.rim().edgeScalePx());
    putArray(out, job.beam.rim().segments());
    put(out, job.jitterPx);
    put(out, job.scale);
    put(out, job.seed);
    putArray(out, job.hits);
    put(out, job.powerY);
    put(out, job.photons);
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
            std::vector<BeamTriangle> triangles = getTriangles(in);
            const long tracedRays = in.get<long>();
            job.beam = GhostBeam::fromTriangles(std::move(triangles), frame, tracedRays);
            const double edgeScalePx = in.get<double>();
            if (!(edgeScalePx >= 0.0 && edgeScalePx < 1e9)) in.fail("a rim's Fresnel scale out of range");
            std::vector<BeamRim::Segment> segments = in.getArray<BeamRim::Segment>();
            if (!segments.empty() && !(edgeScalePx > 0.0)) in.fail("a geometric rim with segments");
            if (edgeScalePx > 0.0) job.beam.ring(BeamRim::fromSegments(std::move(segments), edgeScalePx, frame.heightPx));
            job.jitterPx = in.get<glm::dvec2>();
            job.scale = in.get<glm::dvec3>();
            job.seed = in.get<std::uint64_t>();
            job.hits = in.getArray<SensorHit>();
            job.powerY = in.get<double>();
            job.photons = in.get<std::int64_t>();
        } else {
            in.fail("an unknown record");
        }
        ++read.jobs;
    }
    return read;
}

}  // namespace flare::renderer
