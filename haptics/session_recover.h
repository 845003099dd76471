#pragma once
// Recovering a session a killed run left as PATH.partial (docs/formats.md, Recovering a
// session). The writer flushes its rows every ~1 s, so the file holds every row up to about
// a second before the kill; but its superblock still says "open for write" (h5py refuses
// it), its columns may differ in length by the block being written, and its summary
// attributes are missing.

#include <cstddef>
#include <string>

namespace hapvox::haptics {

struct RecoveredSession {
  std::size_t rows = 0;
  double first_time_s = 0.0;
  double last_time_s = 0.0;
};

/// Writes a complete, h5py-readable copy of the unfinished session `partial_path` to
/// `output_path` (through OUTPUT.recovering, engine/io/output_file.h): every per-tick column
/// cut to the rows all of them hold, attributes rows, complete = 1 and recovered = 1. The
/// input is never changed. Throws InputError naming the file at fault.
RecoveredSession recover_session(const std::string& partial_path, const std::string& output_path);

}  // namespace hapvox::haptics
