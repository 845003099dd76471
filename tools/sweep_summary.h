#pragma once
// A sweep's summary (tools/cmd_sweep.cc): DIR/summary.csv, one line per row of the
// manifest, in manifest order (docs/sweeps.md).

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

/// Writes `path` (through PATH.partial): id, status, the row's inputs and options, then
/// from each finished session peak and RMS force (N), contact time (s), compute p99 (us),
/// lateness p99 (us, realtime rows), mass drift (units, plastic rows: final - initial), and
/// a failed row's error. Empty cells where a row has no such value.
void write_sweep_summary(const std::string& path, const std::vector<haptics::SweepRow>& rows,
                         const std::vector<SweepOutcome>& outcomes);

/// `text` as one CSV cell (quoted when it holds a comma, a quote or a line break).
std::string csv_cell(const std::string& text);

}  // namespace hapvox::cli
