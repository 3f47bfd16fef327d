#include "pipeline/validate_files.h"

#include <tbb/task_group.h>

#include "report/frame_files.h"
#include "report/report_files.h"

namespace penumbra {

void write_validate_outputs(OutputTransaction& out, const Scenario& scenario, const ValidateResult& r,
                            const ValidateFiles& files) {
    const bool frames = files.frames;
    nlohmann::json oracle_info = r.oracle->info;
    // The frames (--frames: oracle.exr and raster.exr, the largest files) are written beside the
    // report's images; oracle.json, which times their writing, follows both.
    tbb::task_group frame_files;
    if (frames) {
        frame_files.run([&] {
            oracle_info["seconds"]["write"] = report::write_oracle_images(out, r.oracle->frame);
            report::write_raster_outputs(out, scenario, r.technique, r.raster, r.raster_timings);
        });
    } else {
        out.write_json(r.engine.is_null() ? "raster.json" : "engine.json", r.raster_info);
    }
    // The report reads nothing of the oracle's write time: its inputs are the run's own.
    report::ReportInputs in = report_inputs(scenario, r, r.oracle->info);
    in.tint_cascades = files.tint_cascades;
    in.errors_exr = files.frames || files.errors;
    report::write_report(out, in, r.oracle->frame, r.raster.frame, r.score, r.report);
    frame_files.wait();
    out.write_json("oracle.json", oracle_info);
}

}  // namespace penumbra
