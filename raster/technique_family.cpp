#include "raster/technique_family.h"

#include <fmt/format.h>

#include <stdexcept>

namespace penumbra::raster {

namespace {

std::deque<FamilyEntry>& registry() {
    // A deque: entries keep their addresses as families are registered.
    static std::deque<FamilyEntry> families = {depth_map_family_entry(), averaged_area_family_entry(),
                                               cascaded_family_entry(), planar_projection_family_entry()};
    [[maybe_unused]] static const bool filterable = (add_filterable_families(families), true);
    [[maybe_unused]] static const bool volumes = (families.push_back(shadow_volume_family_entry()), true);
    return families;
}

}  // namespace

const std::deque<FamilyEntry>& technique_families() {
    return registry();
}

std::vector<std::string> sweep_keys_of(const FamilyEntry& family) {
    std::vector<std::string> keys;
    for (const KnobDecl& k : family.knobs) keys.push_back(k.key);
    keys.insert(keys.end(), family.sweep_keys.begin(), family.sweep_keys.end());
    return keys;
}

const FamilyEntry* find_technique_family(std::string_view name) {
    for (const FamilyEntry& f : registry())
        if (f.name == name) return &f;
    return nullptr;
}

const FamilyEntry& family_of(const Technique& t) {
    const FamilyEntry* f = find_technique_family(t.family);
    if (!f) throw std::logic_error(fmt::format("technique family \"{}\" is not registered", t.family));
    return *f;
}

void register_technique_family(FamilyEntry entry) {
    if (entry.name.empty()) throw std::invalid_argument("register_technique_family: a family needs a name");
    if (find_technique_family(entry.name))
        throw std::invalid_argument(
            fmt::format("register_technique_family: \"{}\" is already a technique family", entry.name));
    if (!entry.parse || !entry.write || !entry.hints || !entry.memory || !entry.make)
        throw std::invalid_argument(
            fmt::format("register_technique_family: \"{}\" needs parse, write, hints, memory and make", entry.name));
    registry().push_back(std::move(entry));
}

}  // namespace penumbra::raster
