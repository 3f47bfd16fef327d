// penumbra's version, as `penumbra --version` prints it and report.json records it.
#pragma once

namespace penumbra {

const char* version_string();

}  // namespace penumbra
