// KissFFT's 2-D complex transform, bound privately. The engine must not take KissFFT's symbols
// from the process's global scope: a host program may already hold another library that defines
// the same names (Blender loads libcodec2 through FFmpeg, which exports its own kiss_fft,
// kiss_fft_alloc, kiss_fftnd...). The dynamic linker binds the first definition it finds, so the
// engine and even libkissfft's own internal calls would run codec2's copy: other roundings (the
// starburst differing from the CLI's in the last bits) or, with a different struct layout, memory
// errors. The library is therefore opened on first use with its own symbols first
// (RTLD_LOCAL | RTLD_DEEPBIND), the engine is not linked to it, and the plans live in memory the
// engine owns (kiss_fftnd_alloc's caller-supplied buffer), so no allocation crosses allocators.
#pragma once

#include <vector>

#include <kiss_fft.h>

namespace flare {

class KissFft2d {
public:
    // A forward or inverse transform of rows × cols complex values; throws std::runtime_error
    // naming the library when it cannot be opened or a plan cannot be made.
    KissFft2d(int rows, int cols, bool inverse);
    void operator()(const kiss_fft_cpx* in, kiss_fft_cpx* out) const;

    // kiss_fft_next_fast_size: the next size ≥ n with only factors 2, 3 and 5.
    static int nextFastSize(int n);

private:
    std::vector<unsigned char> plan_;  // kiss_fftnd's state, in memory the engine owns
};

}  // namespace flare
