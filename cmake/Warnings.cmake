# One INTERFACE target that every penumbra target links for warnings and sanitizers.
add_library(penumbra_warnings INTERFACE)
target_compile_options(penumbra_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow
  -Wnon-virtual-dtor -Wcast-align -Woverloaded-virtual -Wimplicit-fallthrough)
if(PENUMBRA_WERROR)
  target_compile_options(penumbra_warnings INTERFACE -Werror)
endif()
if(PENUMBRA_SANITIZE)
  target_compile_options(penumbra_warnings INTERFACE -fsanitize=address,undefined
    -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
  target_link_options(penumbra_warnings INTERFACE -fsanitize=address,undefined)
endif()
