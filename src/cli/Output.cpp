#include "Output.h"

namespace flare::cli {

std::string jsonText(const nlohmann::json& j) {
    return j.dump(2, ' ', /*ensure_ascii=*/false, nlohmann::json::error_handler_t::replace);
}

}  // namespace flare::cli
