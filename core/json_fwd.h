// The name sdfkit uses for nlohmann::json, without the library's 25,000 lines: enough for headers that only pass or
// return JSON values. Sources that build, read or print JSON include core/json.h.
#pragma once

#include <nlohmann/json_fwd.hpp>

namespace sdfkit {
using Json = nlohmann::json;
}  // namespace sdfkit
