#include "common/version.h"

namespace penumbra {

const char* version_string() {
    return PENUMBRA_VERSION;
}

}  // namespace penumbra
