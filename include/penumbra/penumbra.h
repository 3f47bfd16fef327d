// penumbra as a library: everything a program needs to validate a shadow technique against
// the ray-traced truth in-process (docs/library.md). Link the CMake target penumbra::penumbra.
//
//   penumbra::Scenario sc = penumbra::load_scenario("scenario.json");
//   auto technique = penumbra::raster::parse_technique(sc.technique, "technique", sc.lights);
//   auto gate = penumbra::metrics::parse_gate(sc.gate, "gate", sc.lights, penumbra::metrics::GateOrigin::scenario);
//   penumbra::ValidateResult r = penumbra::validate(sc, technique, gate, {});
//   r.score.lights[0].rate(penumbra::metrics::PixelClass::acne);
//
// A technique family of one's own (docs/raster.md, "Adding a technique family"): fill a
// penumbra::raster::FamilyEntry and register it before parsing; techniques then name it in "family".
//   penumbra::raster::register_technique_family(my_family_entry());
//
// An engine's own shadow image instead of penumbra's raster path (docs/compare.md):
//   penumbra::EngineFrame f = penumbra::load_engine_frame(sc, "shadow.exr", {0, 1, 2}, std::nullopt, {});
//   penumbra::ValidateResult c = penumbra::compare(sc, f);
#pragma once

#include "common/errors.h"
#include "common/scenario.h"
#include "common/version.h"
#include "metrics/classification.h"
#include "metrics/gate.h"
#include "metrics/metric_table.h"
#include "pipeline/compare.h"
#include "pipeline/compare_files.h"
#include "pipeline/validate.h"
#include "pipeline/validate_files.h"
#include "raster/depth_map.h"
#include "raster/raster.h"
#include "raster/technique.h"
#include "raster/technique_family.h"
#include "stress/stress_files.h"
#include "stress/suite.h"
#include "sweep/sweep_files.h"
#include "tune/tune_files.h"
