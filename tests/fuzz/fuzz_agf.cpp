// libFuzzer entry point: the glass catalogue reader (AgfCatalog::parse after decodeText) and what a parsed glass is used for. See FuzzTargets.h and scripts/fuzz.sh.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "FuzzTargets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    flare::fuzz::agfInput(std::string_view(reinterpret_cast<const char*>(data), size));
    return 0;
}
