// A beam's record between ranks (PassWire.h): read back, it rasterises bit for bit as the traced
// beam in every band (its large and small triangles, its ringing rim), though its triangles take
// less than half the bytes of the whole triangles; a cut record is an error, not a wrong beam. A
// band owner's part of a beam rasterises its bands bit for bit as the whole, and a band's image
// read back adds to the film exactly as the buffer it was written from.
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "flare/film/Film.h"
#include "flare/render/BeamStrategy.h"
#include "flare/render/PassWire.h"
#include "flare/render/PhotonBatches.h"

namespace flare {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A disk of `sides` triangles about `centre` (vertices shared exactly, as a mesh gives them) whose
// irradiance varies over it, and a few small triangles (under a pixel², splatted at points) beside.
renderer::BeamJob diskJob(const FilmFrame& frame, glm::dvec2 centre, double radiusPx, int sides) {
    std::vector<BeamTriangle> triangles;
    auto corner = [&](int k) {
        const double a = 2.0 * kPi * k / sides;
        return centre + radiusPx * glm::dvec2(std::cos(a), std::sin(a));
    };
    for (int k = 0; k < sides; ++k) {
        BeamTriangle t;
        const glm::dvec2 v[3] = {centre, corner(k), corner(k + 1)};
        for (int c = 0; c < 3; ++c) {
            t.pupilMm[c] = v[c] * 0.01;
            t.pixel[c] = v[c];
            t.throughput[c] = 0.5 + 0.25 * std::sin(v[c].x);
            t.irradiance[c] = 1.0 + 0.1 * c + 0.01 * k;
        }
        t.imageAreaPx2 = 0.5 * std::abs((v[1].x - v[0].x) * (v[2].y - v[0].y) - (v[2].x - v[0].x) * (v[1].y - v[0].y));
        t.pupilAreaMm2 = t.imageAreaPx2 * 1e-4;
        triangles.push_back(t);
    }
    for (int k = 0; k < 5; ++k) {
        BeamTriangle t;
        const glm::dvec2 at = centre + glm::dvec2(radiusPx + 3.0 + 7.3 * k, -20.0 + 11.1 * k);
        const glm::dvec2 v[3] = {at, at + glm::dvec2(0.6, 0.1), at + glm::dvec2(0.2, 0.7)};
        for (int c = 0; c < 3; ++c) {
            t.pupilMm[c] = glm::dvec2(5.0 + k, 5.0 + 0.1 * c);  // (apart from the disk's pupil)
            t.pixel[c] = v[c];
            t.throughput[c] = 0.3 + 0.1 * c;
            t.irradiance[c] = 2.0;
        }
        t.imageAreaPx2 = 0.19;
        t.pupilAreaMm2 = 0.004 + 0.001 * k;
        t.small = true;
        triangles.push_back(t);
    }
    renderer::BeamJob job;
    job.beam = GhostBeam::fromTriangles(std::move(triangles), frame, 1234);
    job.beam.ring(1.7);
    job.jitterPx = glm::dvec2(0.31, -0.27);
    job.scale = glm::dvec3(0.9, 1.0, 1.1);
    job.seed = 0x5eed;
    job.powerY = 2.5;
    job.photons = 7;
    return job;
}

std::vector<double> bandImage(const renderer::BeamJob& job, const FilmFrame& frame, int band) {
    std::vector<double> rows(static_cast<size_t>(Film::kBandRows) * frame.widthPx * 3, 0.0);
    job.beam.rasterise(band, job.jitterPx, job.scale, job.seed, rows.data());
    return rows;
}

TEST(PassWire, ABeamReadBackRasterisesBitwiseAsTracedFromLessThanHalfItsTriangles) {
    const FilmFrame frame{200, 150, 20.0, 15.0, 0.1};
    const renderer::BeamJob traced = diskJob(frame, glm::dvec2(90.3, 70.6), 45.0, 96);
    ASSERT_FALSE(traced.beam.rim().empty());
    std::vector<char> message;
    renderer::writeBeam(1, traced, message);

    std::vector<renderer::BatchResult> batches;
    std::vector<renderer::BeamJob> beams(3);
    const renderer::PassMessage read = renderer::readPassResults(message, frame, batches, beams);
    EXPECT_EQ(read.jobs, 1);
    const renderer::BeamJob& copy = beams[1];
    EXPECT_TRUE(beams[0].beam.empty() && beams[2].beam.empty());
    EXPECT_EQ(copy.beam.tracedRays(), 1234);
    EXPECT_EQ(copy.seed, traced.seed);
    EXPECT_EQ(copy.powerY, traced.powerY);
    EXPECT_EQ(copy.beam.rim().segmentCount(), traced.beam.rim().segmentCount());
    bool anyLight = false;
    for (int band = 0; band < (frame.heightPx + Film::kBandRows - 1) / Film::kBandRows; ++band) {
        const std::vector<double> a = bandImage(traced, frame, band), b = bandImage(copy, frame, band);
        EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0) << "band " << band;
        for (double v : a) anyLight = anyLight || v != 0.0;
    }
    EXPECT_TRUE(anyLight);
    // The record, less its rim's segments (as many as the rim's edges: all of this fan's, a few
    // percent of a real beam's), holds under half the bytes of the whole triangles.
    const size_t rimBytes = traced.beam.rim().segmentCount() * sizeof(BeamRim::Segment);
    ASSERT_LT(rimBytes, message.size());
    EXPECT_LT(message.size() - rimBytes, traced.beam.triangles().size() * sizeof(BeamTriangle) / 2);

    // Cut anywhere, the record is refused.
    for (size_t cut : {message.size() - 1, message.size() / 2, size_t{9}}) {
        const std::vector<char> shorter(message.begin(), message.begin() + static_cast<long>(cut));
        EXPECT_THROW(renderer::readPassResults(shorter, frame, batches, beams), std::runtime_error) << cut;
    }
}

// Every group of bands a rank may own: the beam's part for it (a fraction of the record, with the
// small triangles' seed indices and the rim's segments reaching it) rasterises each of those
// bands bit for bit as the whole beam, and holds nothing for a group no light reaches.
TEST(PassWire, ABandOwnersPartOfABeamRasterisesItsBandsBitwiseAsTheWhole) {
    const FilmFrame frame{200, 230, 20.0, 23.0, 0.1};
    const int bands = (frame.heightPx + Film::kBandRows - 1) / Film::kBandRows;  // 8
    // The disk over rows 20–161 (bands 0–5 with its rim) and its small triangles beside it; ringing.
    const renderer::BeamJob traced = diskJob(frame, glm::dvec2(90.3, 90.6), 70.0, 96);
    ASSERT_FALSE(traced.beam.rim().empty());
    std::vector<char> whole;
    renderer::writeBeam(0, traced, whole);
    for (int first = 0; first < bands; ++first)
        for (int last = first; last < bands; ++last) {
            SCOPED_TRACE("bands " + std::to_string(first) + " to " + std::to_string(last));
            std::vector<char> message;
            renderer::writeBeam(0, traced, first, last, false, message);
            std::vector<renderer::BatchResult> batches;
            std::vector<renderer::BeamJob> beams(1);
            renderer::readPassResults(message, frame, batches, beams);
            if (first > 5) {
                EXPECT_TRUE(message.empty());
                continue;
            }
            EXPECT_LT(message.size(), whole.size());
            // (Every triangle of the fan reaches its centre's band, 2.)
            if (first > 2 || last < 2) EXPECT_LT(beams[0].beam.triangles().size(), traced.beam.triangles().size());
            // The part arrives in the whole beam's order (by band, GhostBeam::bucketByBand), which the
            // reader keeps as it is rather than sorting it again: its triangles are the whole's, in order.
            const GhostBeam& part = beams[0].beam;
            for (size_t n = 0; n < part.triangles().size(); ++n) {
                ASSERT_LT(part.seedIndex(n), traced.beam.triangles().size());
                if (n > 0) EXPECT_LT(part.seedIndex(n - 1), part.seedIndex(n)) << n;
                EXPECT_EQ(std::memcmp(&part.triangles()[n].pixel, &traced.beam.triangles()[part.seedIndex(n)].pixel,
                                      sizeof(BeamTriangle::pixel)),
                          0)
                    << n;
            }
            for (int band = first; band <= last; ++band) {
                const std::vector<double> a = bandImage(traced, frame, band), b = bandImage(beams[0], frame, band);
                EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0) << "band " << band;
            }
        }
}

TEST(PassWire, ABandImageReadBackAddsToTheFilmAsItsBuffer) {
    const FilmFrame frame{200, 150, 20.0, 15.0, 0.1};
    const renderer::BeamJob traced = diskJob(frame, glm::dvec2(60.3, 70.6), 25.0, 48);
    FilmSettings settings;
    settings.widthPx = frame.widthPx, settings.heightPx = frame.heightPx;
    settings.widthMm = frame.widthMm, settings.heightMm = frame.heightMm;
    Film direct(settings, 2), copied(settings, 2);
    const int bands = direct.bandCount();  // the last band is cut (150 rows)
    std::vector<char> message;
    for (int band = 0; band < bands; ++band) {
        std::vector<double> rows = bandImage(traced, frame, band);
        direct.addBand(band, 1, rows.data(), band % 2 == 0);
        renderer::writeBandImage(band, 1, band % 2 == 0, rows.data(), frame.widthPx, frame.heightPx, 0, frame.widthPx, message);
    }
    renderer::writeBandCosts(0, std::vector<double>(bands, 0.25), 3.0, 1.5, message);
    const renderer::BandMessage read = renderer::readBandMessage(message, frame.widthPx, frame.heightPx);
    ASSERT_EQ(read.images.size(), static_cast<size_t>(bands));
    EXPECT_EQ(read.bandSeconds.size(), static_cast<size_t>(bands));
    EXPECT_EQ(read.phaseS, 3.0);
    EXPECT_EQ(read.phaseCpuS, 1.5);
    // Only the runs holding light travel: the disk covers under a third of the frame.
    EXPECT_LT(message.size(), static_cast<size_t>(frame.widthPx) * frame.heightPx * 3 * sizeof(double) / 3);
    std::vector<double> rows;
    for (const renderer::BandImage& image : read.images) {
        EXPECT_EQ(image.layer, 1);
        EXPECT_EQ(image.inTotal, image.band % 2 == 0);
        renderer::readBandImage(message, image, frame.widthPx, frame.heightPx, rows);
        copied.addBand(image.band, image.layer, rows.data(), image.inTotal);
    }
    direct.endPass(1000);
    copied.endPass(1000);
    for (int layer = 0; layer < 2; ++layer)
        EXPECT_EQ(direct.irradianceXyz(layer, 1000.0), copied.irradianceXyz(layer, 1000.0)) << layer;
    EXPECT_EQ(direct.varianceRgb(), copied.varianceRgb());
    // A cut message is refused.
    const std::vector<char> shorter(message.begin(), message.begin() + static_cast<long>(message.size() / 2));
    EXPECT_THROW(renderer::readBandMessage(shorter, frame.widthPx, frame.heightPx), std::runtime_error);
}

}  // namespace
}  // namespace flare
