#include "haptics/sweep_manifest.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <optional>

#include "engine/errors.h"
#include "engine/input_limits.h"
#include "engine/text_file.h"
#include "engine/toml_reporter.h"
#include "engine/volume_io.h"

namespace hapvox::haptics {
namespace {

namespace fs = std::filesystem;

// Flags a row may not set: the sweep sets them (its output, its inputs, a quiet run), or
// they would write beside the row's session where another row's could collide.
const char* const kReservedOptions[] = {"output",     "o",      "volume", "v",         "model",
                                        "materials",  "quiet",  "q",      "trace-out", "sculpt-out",
                                        "render-dir", "device", "help",   "h",         "trace"};

using Reporter = engine::TomlReporter;  // engine/toml_reporter.h

std::string resolved(const std::string& path, const std::string& base_dir) {
  if (path.empty() || fs::path(path).is_absolute() || base_dir.empty()) return path;
  return (fs::path(base_dir) / path).lexically_normal().string();
}

// A volume is a generator spec or a path.
std::string resolved_volume(const std::string& spec, const std::string& base_dir) {
  return engine::is_generator_spec(spec) ? spec : resolved(spec, base_dir);
}

// A string; empty only where `may_be_empty` (materials: "" for none).
const std::string& string_of(const Reporter& r, const std::string& key, const toml::node& node,
                             bool may_be_empty = false) {
  const auto* value = node.as_string();
  if (value == nullptr) r.fail(node, key + " must be a string");
  if (!may_be_empty && value->get().empty()) r.fail(node, key + " must not be empty");
  return value->get();
}

// A string or a list of strings (not empty).
std::vector<std::string> strings_of(const Reporter& r, const std::string& key,
                                    const toml::node& node, bool may_be_empty = false) {
  std::vector<std::string> out;
  if (const toml::array* array = node.as_array()) {
    if (array->empty()) r.fail(node, key + " must not be an empty list");
    for (const toml::node& e : *array) out.push_back(string_of(r, key, e, may_be_empty));
  } else {
    out.push_back(string_of(r, key, node, may_be_empty));
  }
  return out;
}

// An option's value as the replay's flag takes it: a number in its shortest exact form,
// a string as it is, true as the bare flag ("") and false as no flag (nullopt).
std::optional<std::string> option_value(const Reporter& r, const std::string& key,
                                        const toml::node& node) {
  if (const auto* b = node.as_boolean()) {
    if (b->get()) return std::string();
    return std::nullopt;
  }
  if (const auto* i = node.as_integer()) return std::to_string(i->get());
  if (const auto* f = node.as_floating_point()) {
    const double v = f->get();
    if (!std::isfinite(v)) r.fail(node, "option " + key + " must be finite");
    // A whole number as one (2e5: "200000"), else the shortest text that reads back exact.
    if (std::abs(v) < 1e15 && v == std::trunc(v)) {
      return std::to_string(static_cast<long long>(v));
    }
    char text[32];
    const auto result = std::to_chars(text, text + sizeof text, v);
    return std::string(text, result.ptr);
  }
  if (const auto* s = node.as_string()) return s->get();
  r.fail(node, "option " + key + " must be a number, a string or true/false");
}

// One option's values (a value or a non-empty list of them), each nullopt for "not given".
std::vector<std::optional<std::string>> option_values(const Reporter& r, const std::string& key,
                                                      const toml::node& node) {
  std::vector<std::optional<std::string>> out;
  if (const toml::array* array = node.as_array()) {
    if (array->empty()) r.fail(node, "option " + key + " must not be an empty list");
    for (const toml::node& e : *array) {
      if (e.is_array() || e.is_table()) r.fail(e, "option " + key + " must list plain values");
      out.push_back(option_value(r, key, e));
    }
  } else {
    out.push_back(option_value(r, key, node));
  }
  return out;
}

using OptionGrid = std::vector<std::pair<std::string, std::vector<std::optional<std::string>>>>;

// An options table: each flag's values, by name (toml++ keeps keys sorted).
OptionGrid options_of(const Reporter& r, const toml::node& node, bool lists_allowed) {
  const toml::table* table = node.as_table();
  if (table == nullptr) r.fail(node, "options must be a table of replay flags");
  OptionGrid grid;
  for (const auto& [key, value] : *table) {
    const std::string name(key.str());
    if (name.empty() || name.front() == '-') {
      r.fail(value, "option '" + name + "': name replay's flags without their dashes");
    }
    for (const char* reserved : kReservedOptions) {
      if (name == reserved) {
        r.fail(value, "option '" + name + "' is set by the sweep (each row's inputs and output)");
      }
    }
    if (!lists_allowed && value.is_array()) {
      r.fail(value, "option " + name + ": a row takes one value (lists belong to the grid)");
    }
    grid.emplace_back(name, option_values(r, name, value));
  }
  return grid;
}

// Every combination of the grid's values, the last option varying fastest.
std::vector<std::vector<std::pair<std::string, std::string>>> expand(const OptionGrid& grid) {
  std::vector<std::vector<std::pair<std::string, std::string>>> out(1);
  for (const auto& [name, values] : grid) {
    std::vector<std::vector<std::pair<std::string, std::string>>> next;
    for (const auto& partial : out) {
      for (const auto& value : values) {
        auto row = partial;
        if (value) row.emplace_back(name, *value);
        next.push_back(std::move(row));
      }
    }
    out = std::move(next);
  }
  return out;
}

// The rows the manifest describes, counted before any is made (a 31 kB grid may describe a
// billion): the product of the grid's axes, plus the explicit rows. In doubles, which do not
// overflow where the product of a few lists' sizes would.
void check_row_count(const Reporter& r, const toml::node* grid_node,
                     std::initializer_list<std::size_t> axes, const OptionGrid& options,
                     const toml::array* rows) {
  double count = 0.0;
  if (grid_node != nullptr) {
    count = 1.0;
    for (const std::size_t size : axes) count *= static_cast<double>(size);
    for (const auto& [name, values] : options) count *= static_cast<double>(values.size());
  }
  if (rows != nullptr) count += static_cast<double>(rows->size());
  const std::uint64_t limit = engine::input_limits().max_sweep_rows;
  if (count > static_cast<double>(limit)) {
    char text[32];
    std::snprintf(text, sizeof text, "%.0f", count);
    r.fail(grid_node != nullptr ? Reporter::line(*grid_node) : 1,
           std::string("describes ") + text + " replays, " +
               engine::over_limit(limit, "rows", "--max-sweep-rows"));
  }
}

SweepRow explicit_row(const Reporter& r, const toml::table& table, const std::string& base_dir) {
  SweepRow row;
  row.line = Reporter::line(table);
  bool has_trace = false, has_volume = false;
  for (const auto& [key, node] : table) {
    const std::string name(key.str());
    if (name == "trace") {
      row.trace = resolved(string_of(r, name, node), base_dir);
      has_trace = true;
    } else if (name == "volume") {
      row.volume = resolved_volume(string_of(r, name, node), base_dir);
      has_volume = true;
    } else if (name == "model") {
      row.model = string_of(r, name, node);
    } else if (name == "materials") {
      row.materials = resolved(string_of(r, name, node, true), base_dir);
    } else if (name == "options") {
      for (auto& [option, values] : options_of(r, node, false)) {
        if (values.front()) row.options.emplace_back(option, *values.front());
      }
    } else {
      r.fail(node, "unknown key '" + name +
                       "' in [[row]] (expected trace, volume, model, materials, options)");
    }
  }
  if (!has_trace) r.fail(row.line, "[[row]] has no trace");
  if (!has_volume) r.fail(row.line, "[[row]] has no volume");
  return row;
}

void check_model(const Reporter& r, int line, const std::string& model) {
  if (model != "voxel" && model != "fem") {
    r.fail(line, "unknown model '" + model + "' (voxel or fem)");
  }
}

}  // namespace

SweepManifest parse_sweep_manifest(std::string_view text, const std::string& source,
                                   const std::string& base_dir) {
  const Reporter r(source);
  const toml::table root = engine::parse_toml(text, r);
  SweepManifest manifest;
  manifest.source = source;
  std::vector<std::string> traces, volumes, models{"voxel"}, materials{""};
  const toml::node *traces_node = nullptr, *volumes_node = nullptr;
  OptionGrid grid;
  const toml::array* rows = nullptr;
  for (const auto& [key, node] : root) {
    const std::string name(key.str());
    if (name == "traces") {
      traces_node = &node;
      for (const std::string& t : strings_of(r, name, node))
        traces.push_back(resolved(t, base_dir));
    } else if (name == "volumes") {
      volumes_node = &node;
      for (const std::string& v : strings_of(r, name, node)) {
        volumes.push_back(resolved_volume(v, base_dir));
      }
    } else if (name == "models") {
      models = strings_of(r, name, node);
      for (const std::string& m : models) check_model(r, Reporter::line(node), m);
    } else if (name == "materials") {
      materials.clear();
      for (const std::string& m : strings_of(r, name, node, true)) {
        materials.push_back(resolved(m, base_dir));
      }
    } else if (name == "options") {
      grid = options_of(r, node, true);
    } else if (name == "row") {
      rows = node.as_array();
      if (rows == nullptr || !rows->is_array_of_tables()) {
        r.fail(node, "row must be an array of tables ([[row]])");
      }
    } else {
      r.fail(node, "unknown key '" + name +
                       "' (expected traces, volumes, models, materials, options, [[row]])");
    }
  }
  if ((traces_node == nullptr) != (volumes_node == nullptr)) {
    const toml::node& given = traces_node != nullptr ? *traces_node : *volumes_node;
    r.fail(given, traces_node != nullptr ? "a grid of traces needs volumes too"
                                         : "a grid of volumes needs traces too");
  }
  check_row_count(r, traces_node, {traces.size(), volumes.size(), models.size(), materials.size()},
                  grid, rows);
  if (traces_node != nullptr) {
    const int line = Reporter::line(*traces_node);
    for (const std::string& trace : traces) {
      for (const std::string& volume : volumes) {
        for (const std::string& model : models) {
          for (const std::string& material : materials) {
            for (auto& options : expand(grid)) {
              SweepRow row;
              row.trace = trace;
              row.volume = volume;
              row.model = model;
              row.materials = material;
              row.options = std::move(options);
              row.line = line;
              manifest.rows.push_back(std::move(row));
            }
          }
        }
      }
    }
  } else if (!grid.empty()) {
    r.fail(*root.get("options"), "options need a grid (traces and volumes) to apply to");
  }
  if (rows != nullptr) {
    for (const toml::node& node : *rows) {
      SweepRow row = explicit_row(r, *node.as_table(), base_dir);
      check_model(r, row.line, row.model);
      manifest.rows.push_back(std::move(row));
    }
  }
  if (manifest.rows.empty()) r.fail(1, "no replay: give traces and volumes, or [[row]]s");
  for (SweepRow& row : manifest.rows) {
    std::sort(row.options.begin(), row.options.end());
  }
  return manifest;
}

SweepManifest read_sweep_manifest(const std::string& path) {
  const std::string text = engine::read_text_file(path);
  // Absolute: the rows run in the sweep's directory, not here.
  return parse_sweep_manifest(text, path, fs::absolute(path).parent_path().string());
}

std::uint64_t fnv1a_64(std::string_view bytes, std::uint64_t hash) {
  for (const char c : bytes) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 1099511628211ull;
  }
  return hash;
}

std::uint64_t SweepFileDigests::of(const std::string& path) {
  const auto known = digests_.find(path);
  if (known != digests_.end()) return known->second;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot be read");
  std::uint64_t hash = fnv1a_64("");
  std::vector<char> piece(1 << 20);
  while (in) {
    in.read(piece.data(), static_cast<std::streamsize>(piece.size()));
    hash = fnv1a_64(std::string_view(piece.data(), static_cast<std::size_t>(in.gcount())), hash);
  }
  if (in.bad()) throw InputError(path, "cannot be read");
  digests_.emplace(path, hash);
  return hash;
}

std::string sweep_row_id(const SweepRow& row, const std::vector<std::string>& volume_files,
                         SweepFileDigests& digests) {
  // Each part with its name and length, so that no two rows' streams can run together.
  std::uint64_t hash = fnv1a_64("hapvox sweep row 2\n");
  auto add = [&hash](const std::string& name, std::string_view bytes) {
    hash = fnv1a_64(name + " " + std::to_string(bytes.size()) + "\n", hash);
    hash = fnv1a_64(bytes, hash);
  };
  auto add_file = [&](const std::string& name, const std::string& path) {
    const std::uint64_t digest = digests.of(path);
    add(name, std::string_view(reinterpret_cast<const char*>(&digest), sizeof digest));
  };
  add_file("trace", row.trace);
  if (volume_files.empty()) {
    add("generator", row.volume);
  } else {
    // A raw file's spec ("ct.raw:dims=64,64,32,...") adds options to its path: they count.
    if (row.volume != volume_files.front()) {
      const bool prefixed = row.volume.rfind(volume_files.front(), 0) == 0;
      add("volume options", prefixed ? row.volume.substr(volume_files.front().size()) : row.volume);
    }
    for (const std::string& file : volume_files) add_file("volume file", file);
  }
  add("model", row.model);
  if (!row.materials.empty()) add_file("materials", row.materials);
  for (const auto& [name, value] : row.options) add("--" + name, value);
  // FNV-1a's last bytes move few bits: a finaliser (splitmix64's) spreads them over all 64,
  // so IDs that differ in one option do not look alike.
  hash = (hash ^ (hash >> 30)) * 0xbf58476d1ce4e5b9ull;
  hash = (hash ^ (hash >> 27)) * 0x94d049bb133111ebull;
  hash ^= hash >> 31;
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

std::vector<std::string> sweep_replay_arguments(const SweepRow& row, const std::string& output) {
  std::vector<std::string> args = {"replay",   row.trace, "--volume",
                                   row.volume, "--model", row.model};
  if (!row.materials.empty()) {
    args.push_back("--materials");
    args.push_back(row.materials);
  }
  for (const auto& [name, value] : row.options) {
    args.push_back("--" + name);
    if (!value.empty()) args.push_back(value);
  }
  args.insert(args.end(), {"-q", "-o", output});
  return args;
}

}  // namespace hapvox::haptics
