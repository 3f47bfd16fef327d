// sweep's files (docs/outputs.md, "sweep"): sweep.csv, sweep.json, pareto.svg and pareto.png
// (error against production time), report.html. Written from the table alone, so a merge of
// shards writes exactly what one run writes.
#pragma once

#include "common/output_files.h"
#include "sweep/sweep.h"

namespace penumbra::sweep {

void write_sweep_outputs(OutputTransaction& out, const Table& t);

}  // namespace penumbra::sweep
