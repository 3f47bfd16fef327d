// Type checks of the glTF 2.0 JSON schema that tinygltf does not enforce (it silently skips
// a "primitives" object where an array belongs, a string where a number belongs, ...).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace penumbra {

// Throws InputError "<label>: <json path>: expected ..." for the first violation.
void check_gltf_schema(const nlohmann::json& doc, const std::string& label);

}  // namespace penumbra
