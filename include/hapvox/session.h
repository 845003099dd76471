#pragma once
// A session file: the HDF5 file every replay and loop writes, one row per force tick
// (/time_s, /force_n, /tool_position_mm, ...) and the run's configuration and summary as
// attributes. Schema in docs/formats.md.

#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace hapvox {

/// A numeric dataset, row-major: shape {ticks} for a column, {ticks, 3} for a vector.
struct Dataset {
  std::vector<double> values;
  std::vector<std::size_t> shape;
};

class Session {
 public:
  /// Reads every numeric dataset and attribute of a session file. Throws InputError(path,
  /// ...) when it is missing or not a hapvox session.
  static Session open(const std::string& path);

  /// Ticks recorded.
  std::size_t rows() const { return rows_; }
  /// Whether the run that wrote it finished (a killed run leaves complete = 0).
  bool complete() const { return complete_; }
  /// Numeric dataset names without the leading '/', e.g. "force_n", "fem/displacement_mm".
  std::vector<std::string> dataset_names() const;
  bool has_dataset(const std::string& name) const;
  /// Throws InputError(path, "no dataset NAME") when it has none by that name.
  const Dataset& dataset(const std::string& name) const;
  /// Attributes as text, in name order.
  const std::vector<std::pair<std::string, std::string>>& attributes() const { return attributes_; }
  std::optional<std::string> attribute(const std::string& name) const;
  /// The file it was read from ("" when the file was temporary and is gone).
  const std::string& path() const { return path_; }

  /// Internal: for replay(), whose temporary file is removed after reading.
  void forget_path() { path_.clear(); }

 private:
  std::string path_;
  std::size_t rows_ = 0;
  bool complete_ = false;
  std::vector<std::pair<std::string, Dataset>> datasets_;
  std::vector<std::pair<std::string, std::string>> attributes_;
};

}  // namespace hapvox
