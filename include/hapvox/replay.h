#pragma once
// `hapvox replay` as a function: the same code, options and checks as the command line, for
// either model, writing the same session file. Use it to script sessions and sweeps; use
// hapvox/loop.h to drive the loop with your own device.

#include <string>
#include <vector>

#include "hapvox/model.h"
#include "hapvox/session.h"
#include "hapvox/volume.h"

namespace hapvox {

struct ReplayOptions {
  std::string volume;  // --volume: a file, a DICOM folder or a generator (Volume::load)
  std::string trace;   // the trace file (.csv, .h5, H3D DeviceLog)
  /// -o: the session file; "" writes a temporary one, reads it back and removes it.
  std::string output;
  ModelOptions model;
  IntensityOptions intensity;  // --threshold, --window
  bool realtime = false;       // --realtime (no SCHED_FIFO, no mlock: --no-rt-priority --no-mlock)
  /// Any other `hapvox replay` flag as typed, e.g. {"--max-force-n", "4", "--fit"}.
  std::vector<std::string> flags;
};

/// Runs the replay and returns its session. Throws InputError with the line `hapvox replay`
/// prints for the same bad input (e.g. "trace.csv: line 3: expected 4 columns, got 2").
Session replay(const ReplayOptions& options);

/// Runs row `row` (0-based, in the manifest's order: docs/sweeps.md) with the replay
/// `hapvox sweep` runs for it, writing its session to `output` ("": a temporary file, read
/// back and removed), and returns the session. Throws InputError for a bad manifest or a row
/// it does not have.
Session run_sweep_row(const std::string& manifest, std::size_t row, const std::string& output = "");

}  // namespace hapvox
