#pragma once
// A sweep's summary (tools/cmd_sweep.cc): DIR/summary.csv and DIR/summary.h5, one row per
// row of the manifest, in manifest order (docs/sweeps.md).

#include <string>
#include <vector>

#include "haptics/sweep_manifest.h"

namespace hapvox::cli {

/// What became of one row.
struct SweepOutcome {
  std::string id;
  std::string status;   // "done", "failed" or "not run"
  std::string session;  // DIR/ID.h5 (read when done)
  std::string error;    // failed: the row's last line of output
};

/// Writes DIR/summary.csv and DIR/summary.h5 (each through a .partial): id, status, the
/// row's inputs and options, then from each finished session its tool diameter (mm) and
/// Young's modulus (Pa, the command line's), peak and RMS force (N), contact
/// time (s), compute p99 (us), lateness p99 (us, realtime rows), mass drift (units, plastic
/// rows: final - initial), and a failed row's error. The CSV has empty cells where a row has
/// no value; the HDF5 file has a 1-D dataset per column under the root, named as the CSV's
/// header (strings fixed-length UTF-8; numbers float64, NaN where a row has none), and the
/// column order in the root's `columns` attribute.
void write_sweep_summaries(const std::string& dir, const std::vector<haptics::SweepRow>& rows,
                           const std::vector<SweepOutcome>& outcomes);

/// `text` as one CSV cell (quoted when it holds a comma, a quote or a line break).
std::string csv_cell(const std::string& text);

}  // namespace hapvox::cli
