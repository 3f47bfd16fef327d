// The message parse_technique refuses a technique object with, "" when it takes it: the technique,
// family and filterable tests check errors by their text.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "common/errors.h"
#include "raster/technique.h"

namespace penumbra::test {

inline std::string technique_error(const nlohmann::json& j) {
    try {
        raster::parse_technique(j, "s.json: technique");
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

}  // namespace penumbra::test
