// The files of `penumbra diff`: diff.json and diff.html, whose class maps are copied from the two
// runs' folders into the page (data URIs), so the page still shows them once the runs are gone.
#pragma once

#include "common/output_files.h"
#include "pipeline/diff.h"

namespace penumbra::diff {

// diff.json and diff.html, added to the transaction. A class map missing from a run's folder
// (a run given as a bare report.json) is named on the page instead of shown.
void write_diff_outputs(OutputTransaction& out, const Run& a, const Run& b, const DiffResult& d);

}  // namespace penumbra::diff
