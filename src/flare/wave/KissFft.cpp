#include "flare/wave/KissFft.h"

#include <dlfcn.h>

#include <mutex>
#include <stdexcept>
#include <string>

#include <kiss_fftnd.h>

#ifndef FLARE_KISSFFT_LIBRARY
#error "FLARE_KISSFFT_LIBRARY (the KissFFT library's soname) is set by src/CMakeLists.txt"
#endif

namespace flare {

namespace {

// The sanitizers' runtime refuses RTLD_DEEPBIND (it would bypass their interceptors) and stops the
// process. A sanitizer build is never loaded into a host that exports KissFFT's names (Blender),
// so it opens the library with its symbols local only.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr int kOwnSymbolsFirst = 0;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
constexpr int kOwnSymbolsFirst = 0;
#else
constexpr int kOwnSymbolsFirst = RTLD_DEEPBIND;
#endif
#else
constexpr int kOwnSymbolsFirst = RTLD_DEEPBIND;
#endif

struct KissFunctions {
    decltype(&kiss_fftnd_alloc) alloc = nullptr;
    decltype(&kiss_fftnd) transform = nullptr;
    decltype(&kiss_fft_next_fast_size) nextFastSize = nullptr;
};

const KissFunctions& functions() {
    static KissFunctions f;
    static std::once_flag once;
    static std::string problem;
    std::call_once(once, [] {
        // Never closed: the plans' code must outlive every caller.
        void* library = dlopen(FLARE_KISSFFT_LIBRARY, RTLD_NOW | RTLD_LOCAL | kOwnSymbolsFirst);
        if (!library) {
            const char* why = dlerror();
            problem = std::string("cannot open ") + FLARE_KISSFFT_LIBRARY + ": " + (why ? why : "unknown error");
            return;
        }
        f.alloc = reinterpret_cast<decltype(f.alloc)>(dlsym(library, "kiss_fftnd_alloc"));
        f.transform = reinterpret_cast<decltype(f.transform)>(dlsym(library, "kiss_fftnd"));
        f.nextFastSize = reinterpret_cast<decltype(f.nextFastSize)>(dlsym(library, "kiss_fft_next_fast_size"));
        if (!f.alloc || !f.transform || !f.nextFastSize)
            problem = std::string(FLARE_KISSFFT_LIBRARY) + " lacks kiss_fftnd_alloc, kiss_fftnd or kiss_fft_next_fast_size";
    });
    if (!problem.empty()) throw std::runtime_error("starburst: " + problem);
    return f;
}

}  // namespace

KissFft2d::KissFft2d(int rows, int cols, bool inverse) {
    const auto& f = functions();
    const int dims[2] = {rows, cols};
    size_t bytes = 0;
    f.alloc(dims, 2, inverse ? 1 : 0, nullptr, &bytes);  // asks for the state's size
    plan_.resize(bytes);
    size_t given = plan_.size();
    if (bytes == 0 || !f.alloc(dims, 2, inverse ? 1 : 0, plan_.data(), &given))
        throw std::runtime_error("starburst: cannot make a KissFFT plan of " + std::to_string(rows) + " x " +
                                 std::to_string(cols));
}

void KissFft2d::operator()(const kiss_fft_cpx* in, kiss_fft_cpx* out) const {
    functions().transform(reinterpret_cast<kiss_fftnd_cfg>(const_cast<unsigned char*>(plan_.data())), in, out);
}

int KissFft2d::nextFastSize(int n) { return functions().nextFastSize(n); }

}  // namespace flare
