#include "engine/labels/materials.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <unordered_map>
#include <utility>

#include "engine/errors.h"
#include "engine/labels/text.h"
#include "engine/text_file.h"
#include "engine/toml_reporter.h"

namespace hapvox::engine::labels {

using detail::number;

namespace {

constexpr std::array<std::string_view, 8> kMaterialKeys = {
    "label", "name",      "youngs_modulus_pa", "poisson_ratio",
    "fixed", "intensity", "density",           "yield_stress_pa"};
constexpr std::array<std::string_view, 5> kRegionKeys = {"label", "side", "fraction", "min_mm",
                                                         "max_mm"};
constexpr std::array<std::string_view, 6> kSideNames = {"-x", "+x", "-y", "+y", "-z", "+z"};

std::string type_name(toml::node_type type) {
  switch (type) {
    case toml::node_type::table:
      return "a table";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a float";
    case toml::node_type::boolean:
      return "a boolean";
    case toml::node_type::date:
      return "a date";
    case toml::node_type::time:
      return "a time";
    case toml::node_type::date_time:
      return "a date-time";
    case toml::node_type::none:
      break;
  }
  return "nothing";
}

template <std::size_t N>
std::string key_list(const std::array<std::string_view, N>& keys) {
  std::string out;
  for (const std::string_view k : keys) out += (out.empty() ? "" : ", ") + std::string(k);
  return out;
}

using Reporter = engine::TomlReporter;  // engine/toml_reporter.h

/// A table's entries in file order (toml++ keeps them sorted by key).
std::vector<std::pair<std::string, const toml::node*>> in_file_order(const toml::table& table) {
  std::vector<std::pair<std::string, const toml::node*>> entries;
  for (const auto& [key, node] : table) {
    entries.emplace_back(std::string(key.str()), &node);
  }
  std::stable_sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) {
    const auto& pa = a.second->source().begin;
    const auto& pb = b.second->source().begin;
    return std::pair(pa.line, pa.column) < std::pair(pb.line, pb.column);
  });
  return entries;
}

double number_of(const Reporter& r, const std::string& key, const toml::node& node) {
  if (!node.is_number()) r.fail(node, key + " must be a number, got " + type_name(node.type()));
  return node.value<double>().value_or(0.0);
}

Label label_of(const Reporter& r, const toml::node& node) {
  if (!node.is_integer()) r.fail(node, "label must be an integer, got " + type_name(node.type()));
  const std::int64_t v = node.value<std::int64_t>().value_or(-1);
  if (v < 0 || v > kMaxLabel) {
    r.fail(node, "label must lie in [0, " + number(kMaxLabel) + "], got " + number(v));
  }
  return static_cast<Label>(v);
}

std::vector<double> numbers_of(const Reporter& r, const std::string& key, const toml::node& node,
                               std::size_t count, const std::string& what) {
  const toml::array* array = node.as_array();
  if (array == nullptr || array->size() != count ||
      !std::all_of(array->begin(), array->end(),
                   [](const toml::node& e) { return e.is_number(); })) {
    r.fail(node, key + " must be " + what);
  }
  std::vector<double> out;
  for (const toml::node& e : *array) {
    const double v = e.value<double>().value_or(0.0);
    if (!std::isfinite(v)) r.fail(node, key + " must hold finite numbers");
    out.push_back(v);
  }
  return out;
}

template <std::size_t N>
void reject_unknown(const Reporter& r, const std::string& key, const toml::node& node,
                    const std::string& table, const std::array<std::string_view, N>& keys) {
  if (std::find(keys.begin(), keys.end(), key) != keys.end()) return;
  r.fail(node,
         "unknown key '" + printable(key) + "' in " + table + " (expected " + key_list(keys) + ")");
}

Material parse_material(const Reporter& r, const toml::table& table) {
  Material m;
  m.line = Reporter::line(table);
  int e_line = 0;
  int nu_line = 0;
  bool has_label = false;
  for (const auto& [key, node] : in_file_order(table)) {
    reject_unknown(r, key, *node, "[[material]]", kMaterialKeys);
    if (key == "label") {
      m.label = label_of(r, *node);
      has_label = true;
    } else if (key == "name") {
      if (!node->is_string())
        r.fail(*node, "name must be a string, got " + type_name(node->type()));
      m.name = node->value<std::string>().value_or("");
    } else if (key == "youngs_modulus_pa") {
      m.elastic.youngs_modulus_pa = number_of(r, key, *node);
      e_line = Reporter::line(*node);
    } else if (key == "poisson_ratio") {
      m.elastic.poisson_ratio = number_of(r, key, *node);
      nu_line = Reporter::line(*node);
    } else if (key == "fixed") {
      if (!node->is_boolean()) {
        r.fail(*node, "fixed must be true or false, got " + type_name(node->type()));
      }
      m.fixed = node->value<bool>().value_or(false);
    } else if (key == "density") {
      const double rho = number_of(r, key, *node);
      if (!(rho >= 0.0 && rho <= 1.0)) {
        r.fail(*node, "density must lie in [0, 1], got " + number(rho));
      }
      m.density = rho;
    } else if (key == "yield_stress_pa") {
      const double yield = number_of(r, key, *node);
      if (!(std::isfinite(yield) && yield > 0.0)) {
        r.fail(*node, "yield stress must be positive and finite, got " + number(yield) + " Pa");
      }
      m.yield_stress_pa = yield;
    } else {  // intensity
      const auto v = numbers_of(r, key, *node, 2, "an array [low, high] of two numbers");
      if (v[0] > v[1]) {
        r.fail(*node,
               "intensity range [" + number(v[0]) + ", " + number(v[1]) + "] has low above high");
      }
      m.intensity = IntensityRange{0, v[0], v[1]};
    }
  }
  if (!has_label) r.fail(m.line, "[[material]] has no label");
  if (e_line == 0)
    r.fail(m.line, "[[material]] for label " + number(m.label) + " has no youngs_modulus_pa");
  if (nu_line == 0)
    r.fail(m.line, "[[material]] for label " + number(m.label) + " has no poisson_ratio");
  validate_material(m.elastic, r.at(e_line), r.at(nu_line));
  if (m.intensity) m.intensity->label = m.label;
  return m;
}

FixedRegion parse_fixed_region(const Reporter& r, const toml::table& table) {
  FixedRegion f;
  f.line = Reporter::line(table);
  const toml::node* side = nullptr;
  const toml::node* fraction = nullptr;
  const toml::node* min_mm = nullptr;
  const toml::node* max_mm = nullptr;
  for (const auto& [key, node] : in_file_order(table)) {
    reject_unknown(r, key, *node, "[[fixed_region]]", kRegionKeys);
    if (key == "label") {
      f.label = label_of(r, *node);
    } else if (key == "side") {
      side = node;
      const auto text = node->value<std::string>();
      const auto it =
          text ? std::find(kSideNames.begin(), kSideNames.end(), *text) : kSideNames.end();
      if (it == kSideNames.end()) {
        r.fail(*node, "side must be one of " + key_list(kSideNames) + ", got " +
                          (text ? "'" + printable(*text) + "'" : type_name(node->type())));
      }
      f.side = static_cast<FixedRegion::Side>(1 + (it - kSideNames.begin()));
    } else if (key == "fraction") {
      fraction = node;
      f.fraction = number_of(r, key, *node);
      if (!(f.fraction > 0.0 && f.fraction <= 1.0)) {
        r.fail(*node, "fraction must lie in (0, 1], got " + number(f.fraction));
      }
    } else {  // min_mm, max_mm
      const auto v = numbers_of(r, key, *node, 3, "an array [x, y, z] of three numbers");
      (key == "min_mm" ? min_mm : max_mm) = node;
      (key == "min_mm" ? f.min_mm : f.max_mm) = Vec3d(v[0], v[1], v[2]);
    }
  }
  if (side != nullptr) {
    if (min_mm != nullptr || max_mm != nullptr) {
      r.fail(f.line, "[[fixed_region]] takes either side or min_mm and max_mm, not both");
    }
    if (!f.label) r.fail(*side, "side needs a label: the side of which label's extent");
  } else {
    if (fraction != nullptr) r.fail(*fraction, "fraction needs a side");
    if (min_mm == nullptr || max_mm == nullptr) {
      r.fail(f.line, "[[fixed_region]] needs either side (with label) or min_mm and max_mm");
    }
    if (!(f.min_mm.array() < f.max_mm.array()).all()) {
      r.fail(*min_mm, "min_mm must lie below max_mm on every axis");
    }
  }
  return f;
}

/// Each label's material: for a lookup per voxel or per label, where Materials::find's
/// search would make the time grow with voxels (or labels) times materials.
std::unordered_map<Label, const Material*> by_label(const Materials& materials) {
  std::unordered_map<Label, const Material*> index;
  for (const Material& m : materials.materials) index.emplace(m.label, &m);
  return index;
}

/// The array of tables under a top-level key, or an error.
const toml::array& tables_of(const Reporter& r, const std::string& key, const toml::node& node) {
  const toml::array* array = node.as_array();
  if (array == nullptr || !array->is_array_of_tables()) {
    r.fail(node, key + " must be an array of tables: write [[" + key + "]]");
  }
  return *array;
}

}  // namespace

// ---------------------------------------------------------------------------------------

bool FixedBox::contains(const Vec3d& p_mm, Label label_at_p) const {
  if (label && *label != label_at_p) return false;
  return (p_mm.array() >= min_mm.array()).all() && (p_mm.array() <= max_mm.array()).all();
}

const Material* Materials::find(Label label) const {
  for (const Material& m : materials) {
    if (m.label == label) return &m;
  }
  return nullptr;
}

std::vector<IntensityRange> Materials::intensity_ranges() const {
  std::vector<IntensityRange> ranges;
  for (const Material& m : materials) {
    if (m.intensity) ranges.push_back(*m.intensity);
  }
  return ranges;
}

std::set<Label> Materials::fixed_labels() const {
  std::set<Label> labels;
  for (const Material& m : materials) {
    if (m.fixed) labels.insert(m.label);
  }
  return labels;
}

Materials parse_materials(std::string_view text, const std::string& source) {
  const Reporter r(source);
  const toml::table root = engine::parse_toml(text, r);
  Materials out;
  out.source = source;
  // Each label's line, for the duplicate check: a search of the materials so far made
  // 200,000 materials take 97 s.
  std::unordered_map<Label, int> first_line;
  for (const auto& [key, node] : in_file_order(root)) {
    if (key == "material") {
      for (const toml::node& table : tables_of(r, key, *node)) {
        Material m = parse_material(r, *table.as_table());
        if (const auto [first, added] = first_line.emplace(m.label, m.line); !added) {
          const auto* label_node = table.as_table()->get("label");
          r.fail(*label_node, "label " + number(m.label) + " is given twice (first at line " +
                                  std::to_string(first->second) + ")");
        }
        out.materials.push_back(std::move(m));
      }
    } else if (key == "fixed_region") {
      for (const toml::node& table : tables_of(r, key, *node)) {
        out.fixed_regions.push_back(parse_fixed_region(r, *table.as_table()));
      }
    } else {
      r.fail(*node, "unknown key '" + printable(key) +
                        "' (expected [[material]] or [[fixed_region]] tables)");
    }
  }
  if (out.materials.empty()) {
    throw InputError(source, "no [[material]] tables (see docs/materials.md)");
  }
  return out;
}

Materials read_materials(const std::string& path) {
  return parse_materials(read_text_file(path), path);
}

void check_labels_have_materials(const LabelMap& map, const Materials& materials,
                                 bool background_needs_material) {
  std::vector<std::pair<Label, std::int64_t>> missing;
  const auto index = by_label(materials);
  for (const auto& [label, count] : map.voxel_counts()) {
    if (label == 0 && !background_needs_material) continue;
    if (!index.contains(label)) missing.emplace_back(label, count);
  }
  if (missing.empty()) return;
  if (missing.size() == 1) {
    throw InputError(materials.source, "label " + number(missing[0].first) + " has no material (" +
                                           number(missing[0].second) + " voxels)");
  }
  std::string list;
  for (const auto& [label, count] : missing) {
    list += (list.empty() ? "" : ", ") + number(label) + " (" + number(count) + " voxels)";
  }
  throw InputError(materials.source, "labels " + list + " have no material");
}

std::vector<FixedBox> resolve_fixed_regions(const Materials& materials, const LabelMap& map) {
  std::vector<FixedBox> boxes;
  for (const FixedRegion& f : materials.fixed_regions) {
    if (f.side == FixedRegion::Side::kNone) {
      boxes.push_back(FixedBox{f.min_mm, f.max_mm, f.label});
      continue;
    }
    // The label's voxel bounding box, faces included.
    Vec3i lo = map.dims();
    Vec3i hi = Vec3i::Constant(-1);
    for (int z = 0; z < map.dims().z(); ++z) {
      for (int y = 0; y < map.dims().y(); ++y) {
        for (int x = 0; x < map.dims().x(); ++x) {
          if (map.at(Vec3i(x, y, z)) != *f.label) continue;
          lo = lo.cwiseMin(Vec3i(x, y, z));
          hi = hi.cwiseMax(Vec3i(x, y, z));
        }
      }
    }
    if (hi.x() < 0) {
      throw InputError(materials.source + ":" + std::to_string(f.line),
                       "[[fixed_region]] names label " + number(*f.label) +
                           ", which the label map does not hold");
    }
    const Vec3d a = map.index_to_world(lo.cast<double>() - Vec3d::Constant(0.5));
    const Vec3d b = map.index_to_world(hi.cast<double>() + Vec3d::Constant(0.5));
    FixedBox box{a.cwiseMin(b), a.cwiseMax(b), f.label};
    const int side = static_cast<int>(f.side) - 1;  // 0 -x, 1 +x, 2 -y, ...
    const int axis = side / 2;
    const double cut = f.fraction * (box.max_mm[axis] - box.min_mm[axis]);
    if (side % 2 == 0) {
      box.max_mm[axis] = box.min_mm[axis] + cut;
    } else {
      box.min_mm[axis] = box.max_mm[axis] - cut;
    }
    boxes.push_back(box);
  }
  return boxes;
}

std::vector<std::uint8_t> fixed_voxels(const LabelMap& map, const Materials& materials) {
  check_labels_have_materials(map, materials);
  const std::vector<FixedBox> boxes = resolve_fixed_regions(materials, map);
  std::vector<std::uint8_t> fixed(map.data().size(), 0);
  const auto index = by_label(materials);
  for (int z = 0; z < map.dims().z(); ++z) {
    for (int y = 0; y < map.dims().y(); ++y) {
      for (int x = 0; x < map.dims().x(); ++x) {
        const Vec3i ijk(x, y, z);
        const Label label = map.at(ijk);
        bool is_fixed = index.at(label)->fixed;
        const Vec3d p = map.index_to_world(ijk.cast<double>());
        for (const FixedBox& box : boxes) is_fixed = is_fixed || box.contains(p, label);
        fixed[static_cast<std::size_t>(map.linear_index(ijk))] = is_fixed ? 1 : 0;
      }
    }
  }
  return fixed;
}

}  // namespace hapvox::engine::labels
