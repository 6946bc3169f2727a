// The inner loop of the starburst's far field (Starburst.cpp, addFarField): one row of the frame,
// several pixels at a time in the lanes of SIMD registers, compiled once per instruction set
// (Google Highway's foreach_target) and run on the widest the processor has.
//
// A far field reaches every pixel of the frame, and each pixel sums every spike's share. On most
// of the frame (85-90 % of the pixel-spike terms on the night plate) a spike's share is its
// averaged sinc² tail over a narrow fan, a closed form of a dozen multiplies and two divisions:
// that is what the lanes compute. The other terms (a pixel near a spike's band: the crop's
// transverse profile, the fan in pieces) and the halo and the corners are left to the caller's
// scalar code (FarRowTerms), pixel by pixel, in the same order as before. Every operation in the
// lanes is the scalar loop's, in its order (FarFieldRow.cpp is compiled with -ffp-contract=off:
// no fused multiply-adds, which baseline x86-64 code never has), so the frame gets the same bits
// either way (test_far_field_row.cpp compares them on every instruction set).
#pragma once

#include <cstddef>

#include <glm/vec3.hpp>

namespace flare::detail {

// Beyond this many sinc² widths (λ/L) from the crop's band across a spike, a pixel sees the
// fringes' average: sincSquaredCumulative's 1 − 1/(2π²z), whose share in a pixel is the closed
// form w/(2π²(t² − ¼)).
inline constexpr double kAveragedTailWidths = 4.0;

// One spike edge's constants for the far field (DiffractionPsf::Spike, in the crop's frame).
struct FarSpike {
    double directionX = 0.0, directionY = 0.0;    // unit, along the spike
    double transverseX = 0.0, transverseY = 0.0;  // unit, across it
    double fanFromRad = 0.0, fanToRad = 0.0;
    double bandLoPx = 0.0, bandHiPx = 0.0;  // where any channel's transverse profile is complete
    double widestPx = 0.0;                  // the widest channel's sinc² (first zero), px
    glm::dvec3 tailScale{0.0};              // the averaged tail's w/(2π²) × line density × crop energy
};

// The near window's taper about one light's crop (0 inside startPx, 1 beyond startPx + widthPx,
// smoothstep between), weighted by the light's share of the far field's energy.
struct FarTaperRing {
    double centreX = 0.0, centreY = 0.0, startPx = 0.0, widthPx = 1.0, weight = 1.0;
};

// The terms the lanes leave to scalar code, for pixel column x of the row being summed: spike s's
// share where it is not the narrow fan's averaged tail, and then the halo and the corners. Each
// adds to `value` (per channel, before the taper).
class FarRowTerms {
public:
    virtual ~FarRowTerms() = default;
    virtual void spikeShare(int x, size_t spike, glm::dvec3& value) const = 0;
    virtual void haloAndCorners(int x, glm::dvec3& value) const = 0;
};

// One row of one far field: pixel centres (x + 0.5, y + 0.5) for x in [0, width), offsets from the
// crop's centre; every pixel whose taper is positive gets taper × (Σ spikes in order, then
// haloAndCorners) added to its xyz (as float), and its Y, in column order, to *rowY.
struct FarRow {
    double pixelY = 0.0;                 // y + 0.5
    double centreX = 0.0, centreY = 0.0; // the crop's centre, px
    int width = 0;
    const FarSpike* spikes = nullptr;
    size_t spikeCount = 0;
    const FarTaperRing* tapers = nullptr;  // one: its weight is not applied (the light's own far field)
    size_t taperCount = 0;
    const FarRowTerms* terms = nullptr;
    float* xyz = nullptr;                // the row's first pixel
    double* rowY = nullptr;
};

void addFarRow(const FarRow& row);

// The same, one pixel at a time: the scalar reference (tests, and the instruction-set check).
void addFarRowScalar(const FarRow& row);

// The instruction set addFarRow runs on (for reports and tests).
const char* farRowTargetName();

}  // namespace flare::detail
