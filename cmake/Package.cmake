# penumbra::penumbra, the installable library: every module in one shared library whose own
# dependencies (Embree, TBB, OpenEXR, libpng, xxHash, the Vulkan loader, fmt, tinygltf) stay private, so a
# consumer needs only the headers its public types use (GLM, nlohmann-json, Vulkan's headers).
# Warnings and sanitizer flags are private to the build. docs/library.md shows how to use it.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(penumbra_modules penumbra_common penumbra_tinygltf penumbra_image_io penumbra_oracle penumbra_raster
  penumbra_metrics penumbra_metrics_gpu penumbra_report penumbra_report_files penumbra_pipeline penumbra_pipeline_files
  penumbra_stress penumbra_stress_files penumbra_tune penumbra_tune_files penumbra_sweep penumbra_sweep_files penumbra_engines)
add_library(penumbra_library SHARED)
foreach(module ${penumbra_modules})
  target_sources(penumbra_library PRIVATE $<TARGET_OBJECTS:${module}>)
endforeach()
set_target_properties(penumbra_library PROPERTIES
  OUTPUT_NAME penumbra EXPORT_NAME penumbra
  VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
target_link_libraries(penumbra_library
  PRIVATE embree TBB::tbb PkgConfig::OPENEXR PkgConfig::PNG ${CMAKE_DL_LIBS} PkgConfig::XXHASH Vulkan::Vulkan fmt::fmt
  PUBLIC glm::glm nlohmann_json::nlohmann_json Vulkan::Headers)
# The public headers use C++20 (std::span, designated initialisers): a consumer gets the
# requirement with the target, whatever its own CMAKE_CXX_STANDARD says.
target_compile_features(penumbra_library INTERFACE cxx_std_20)
# The public headers keep the source tree's module folders under include/penumbra/, so that
# they include each other as they do in the tree ("common/scenario.h").
target_include_directories(penumbra_library INTERFACE
  $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include> $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
  $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/penumbra>)
add_library(penumbra::penumbra ALIAS penumbra_library)

# Every header the umbrella header reaches (the package test fails on a missing one).
set(penumbra_public_headers
  common/alpha_coverage.h common/errors.h common/frames.h common/json_reader.h common/memory_estimate.h common/model_placement.h common/output_files.h
  common/progress.h common/ranges.h common/receivers.h common/scenario.h common/scene.h common/stopwatch.h common/version.h
  metrics/classification.h metrics/gate.h metrics/metric_table.h
  oracle/oracle.h
  pipeline/facing.h pipeline/validate.h pipeline/validate_files.h pipeline/compare.h pipeline/compare_files.h
  raster/cascades.h raster/depth_map.h raster/gpu_passes.h raster/knobs.h raster/light_projection.h raster/raster.h raster/raster_output.h raster/technique.h
  raster/technique_family.h raster/vk_check.h raster/vulkan_context.h
  report/report.h shaders/penumbra_shared.h
  stress/cases.h stress/stress_files.h stress/suite.h
  sweep/sweep.h sweep/sweep_files.h sweep/sweep_table.h
  tune/tune.h tune/tune_files.h tune/tune_report.h)
foreach(header ${penumbra_public_headers})
  get_filename_component(dir ${header} DIRECTORY)
  install(FILES ${PROJECT_SOURCE_DIR}/${header} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/penumbra/${dir})
endforeach()
install(FILES ${PROJECT_SOURCE_DIR}/include/penumbra/penumbra.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/penumbra)
install(TARGETS penumbra_library EXPORT penumbraTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(TARGETS penumbra RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(EXPORT penumbraTargets NAMESPACE penumbra:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/penumbra)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/penumbraConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/penumbraConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/penumbra)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/penumbraConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/penumbraConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/penumbraConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/penumbra)
