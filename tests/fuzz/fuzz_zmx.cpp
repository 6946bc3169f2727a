// libFuzzer entry point: the Zemax reader (parseZemaxText) on .zmx seeds, and what a parsed lens is used for. See FuzzTargets.h and scripts/fuzz.sh.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "FuzzTargets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    flare::fuzz::zmxInput(std::string_view(reinterpret_cast<const char*>(data), size));
    return 0;
}
