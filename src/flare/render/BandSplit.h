// How a distributed pass shares the film's bands among the ranks (RenderDistributed.cpp): each rank
// owns a contiguous group of bands (Film::kBandRows rows each) in row order, rasterises every beam
// over them and sends rank 0 their images. The split changes no bit of the image (a band receives
// the same additions in the same order whichever rank owns it); it only decides who waits. Rank 0
// waiting for the others' band images is time no rank uses, while another rank whose bands are
// done first claims more of the next pass's jobs: so the split balances the ranks' band phases
// with a lead for rank 0. Internal to the renderer.
#pragma once

#include <span>
#include <vector>

namespace flare::renderer {

// How much longer than the others' rank 0's band phase is planned, as a fraction of the mean
// phase: enough that the band costs' change from pass to pass and the images' transfer do not
// leave it waiting.
inline constexpr double kRootBandLead = 0.15;

// The split as bandStart: rank r owns bands [bandStart[r], bandStart[r + 1]); bandStart[0] = 0 and
// bandStart[ranks] = bands.

// By rows: rank r owns bands [⌊r·B/R⌋, ⌊(r + 1)·B/R⌋).
std::vector<int> bandsByRows(int bands, int ranks);

// The split that balances the band phase, from each band's cost (s, or any unit shared with
// `besides`) and each rank's cost besides its bands (at rank 0 every band's hits; decoding,
// encoding): rank r's phase is besides[r] plus its bands' costs; each rank gets bands worth
// t − besides[r], t the mean phase, rank 0 a lead of kRootBandLead · t more (taken from the others
// alike). Each boundary falls where the running cost crosses its target, at the band end nearest
// it. Costs that sum to zero (or are not finite): by rows.
std::vector<int> balancedBands(std::span<const double> bandCost, std::span<const double> besides);

// A rectangle of film pixels, [x0, x1) × [y0, y1).
struct PixelBox {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

// Each band's pixels under the boxes (a pixel under two boxes counts twice), the boxes clipped to
// rows [0, heightPx): a beam's rasterising costs about the pixels its ghost covers, so the beams'
// footprints give the bands' costs before any has been measured (RenderDistributed.cpp). Whole
// pixels, exact in a double below 2⁵³: every rank computes the same counts.
std::vector<double> bandPixels(std::span<const PixelBox> boxes, int heightPx, int bandRows);

}  // namespace flare::renderer
