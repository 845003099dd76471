#pragma once
// A sweep's manifest (`hapvox sweep MANIFEST -o DIR`, docs/sweeps.md): many replays described
// once, as a grid of traces x volumes x models x materials x option values, plus explicit
// rows. TOML, read with toml++:
//
//   traces = ["traces/a.csv", "traces/b.csv"]   # paths relative to the manifest's folder
//   volumes = ["block:dims=48", "data/ct.nrrd"]  # files or generators
//   models = ["voxel"]                           # optional, default ["voxel"]
//   materials = ["", "data/clay_block.toml"]     # optional ("": none), default [""]
//   [options]                                    # optional: `hapvox replay` flags without
//   tool-diameter-mm = [4, 8]                    # their dashes, each a value or a list of
//   plastic = true                               # values (true: the flag given)
//
//   [[row]]                                      # any number: one replay each
//   trace = "traces/c.csv"
//   volume = "block"
//   options = { tool-diameter-mm = 6 }
//
// Each row gets an ID from its inputs: the bytes of its trace, volume and materials files
// (a generator by its spec) and its options as text, so the same replay has the same ID in
// any folder, and a changed input a new one.

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hapvox::haptics {

/// One replay of a sweep.
struct SweepRow {
  std::string trace;   // a path: absolute, or relative to the working directory
  std::string volume;  // a path, or a generator spec
  std::string model = "voxel";
  std::string materials;  // a path, or "" for none
  /// `hapvox replay` flags without their dashes and their values as text, sorted by name;
  /// a flag without a value ("plastic") has the value "".
  std::vector<std::pair<std::string, std::string>> options;
  int line = 0;  // the manifest line it was made from (a grid's: its `traces` line)
};

struct SweepManifest {
  std::string source;  // the manifest's path
  std::vector<SweepRow> rows;
};

/// Parses a manifest's text: the grid expanded in the order traces, volumes, models,
/// materials, then each option in name order (the last varying fastest), then the explicit
/// rows. Relative paths are resolved against `base_dir` (textually; nothing is read).
/// Throws InputError("SOURCE:LINE", problem) for TOML that does not parse, an unknown key,
/// a value of the wrong type, an empty list, a grid without traces or volumes, a manifest
/// with no row, and an option that names what the sweep itself sets (output, volume, model,
/// materials, quiet, ...).
SweepManifest parse_sweep_manifest(std::string_view text, const std::string& source,
                                   const std::string& base_dir);

/// Reads and parses the manifest at `path` (paths relative to its folder, made absolute).
SweepManifest read_sweep_manifest(const std::string& path);

/// Digests of the files a sweep's rows read, each file read once however many rows read it
/// (a thousand rows may share one CT).
class SweepFileDigests {
 public:
  /// 64-bit FNV-1a of the file's bytes (read in pieces). InputError(path, "cannot be read").
  std::uint64_t of(const std::string& path);

 private:
  std::map<std::string, std::uint64_t> digests_;
};

/// The row's ID: 16 hex digits of a 64-bit FNV-1a hash (finalised as splitmix64's) over the
/// digests of its trace, of its volume's files and of its materials file, its model and its
/// options. `volume_files` are the files `hapvox replay` reads for the volume: its header
/// and any data file the header names; none for a generator, whose spec counts instead
/// (as do a raw file's options after its path). The same bytes under other names give the
/// same ID. InputError(path, ...) when a file cannot be read.
std::string sweep_row_id(const SweepRow& row, const std::vector<std::string>& volume_files,
                         SweepFileDigests& digests);

/// The arguments of the `hapvox replay` that runs `row` into `output` (after the program
/// name): replay TRACE --volume VOLUME --model MODEL [--materials M] [--FLAG [VALUE]]... -q
/// -o OUTPUT.
std::vector<std::string> sweep_replay_arguments(const SweepRow& row, const std::string& output);

/// 64-bit FNV-1a of `bytes`, continuing from `hash` (the offset basis by default).
std::uint64_t fnv1a_64(std::string_view bytes, std::uint64_t hash = 14695981039346656037ull);

}  // namespace hapvox::haptics
