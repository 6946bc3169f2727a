// FLARE_ROUNDING_CLONES: compile a function twice, for baseline x86-64 and for SSE4.1, and pick
// the version at load time (the compiler's target_clones, an ifunc on Linux). Scalar code that
// rounds doubles to pixels (std::ceil, std::floor) gets one roundsd instruction for each where the
// baseline emulates it in about eight; the rasterisers spend a tenth of their time there. The
// results are the same bits: rounding is exact, and SSE4.1 brings no fused multiply-add that could
// contract an expression. Elsewhere (other processors, other compilers) it is empty.
//
// GCC only: clang 16 (the fuzz build's, scripts/fuzz.sh) emits the clones and their ifunc under
// names that a call from another translation unit does not reference, so the link fails
// (undefined reference to GhostBeam::rasterise from Render.cpp). clang defines __GNUC__ as well.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(FLARE_NO_TARGET_CLONES)
#define FLARE_ROUNDING_CLONES __attribute__((target_clones("default", "sse4.1")))
#else
#define FLARE_ROUNDING_CLONES
#endif
