// nlohmann::json in full, for the sources (and the few headers holding a Json member or default argument) that
// build, read or print JSON values. Headers that only name Json include core/json_fwd.h.
#pragma once

#include "core/json_fwd.h"

#include <nlohmann/json.hpp>
