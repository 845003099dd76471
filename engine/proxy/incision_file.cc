#include "engine/proxy/incision_file.h"

#include <cmath>
#include <vector>

#include "engine/errors.h"
#include "engine/text_file.h"
#include "engine/toml_reporter.h"

namespace hapvox::engine::proxy {
namespace {

using Eigen::Vector3d;

using Reporter = engine::TomlReporter;  // engine/toml_reporter.h

double number_of(const Reporter& r, const std::string& key, const toml::node& node) {
  if (!node.is_number()) r.fail(node, key + " must be a number");
  const double value = node.value<double>().value_or(NAN);
  if (!std::isfinite(value)) r.fail(node, key + " must be finite");
  return value;
}

Vector3d point_of(const Reporter& r, const std::string& key, const toml::node& node) {
  const toml::array* array = node.as_array();
  if (array == nullptr || array->size() != 3) r.fail(node, key + " must be [x, y, z] (mm)");
  return Vector3d(number_of(r, key, *array->get(0)), number_of(r, key, *array->get(1)),
                  number_of(r, key, *array->get(2)));
}

const toml::array& array_of(const Reporter& r, const std::string& key, const toml::node& node) {
  const toml::array* array = node.as_array();
  if (array == nullptr || array->empty()) r.fail(node, key + " must be a non-empty array");
  return *array;
}

}  // namespace

IncisionFile parse_incision(std::string_view text, const std::string& source) {
  const Reporter r(source);
  const toml::table root = engine::parse_toml(text, r);
  IncisionFile out;
  out.source = source;
  const toml::node *width = nullptr, *polyline = nullptr, *sweep = nullptr, *triangles = nullptr;
  for (const auto& [key, node] : root) {
    const std::string name(key.str());
    if (name == "width_mm") {
      width = &node;
    } else if (name == "polyline_mm") {
      polyline = &node;
    } else if (name == "sweep_mm") {
      sweep = &node;
    } else if (name == "triangles_mm") {
      triangles = &node;
    } else if (name == "at_s") {
      out.at_s = number_of(r, name, node);
      if (*out.at_s < 0) r.fail(node, "at_s must be >= 0 s");
    } else {
      r.fail(node, "unknown key '" + printable(name) +
                       "' (expected width_mm, polyline_mm, sweep_mm, triangles_mm, at_s)");
    }
  }
  if (width == nullptr) throw InputError(source, "width_mm is missing");
  out.width_mm = number_of(r, "width_mm", *width);
  if (out.width_mm <= 0) r.fail(*width, "width_mm must be > 0");
  if (polyline == nullptr && triangles == nullptr) {
    throw InputError(source, "no cut: give polyline_mm (with sweep_mm) or triangles_mm");
  }
  if (polyline != nullptr && triangles != nullptr) {
    r.fail(*triangles, "give polyline_mm or triangles_mm, not both");
  }
  if (polyline != nullptr) {
    if (sweep == nullptr) throw InputError(source, "polyline_mm needs sweep_mm");
    std::vector<Vector3d> points;
    for (const toml::node& p : array_of(r, "polyline_mm", *polyline)) {
      points.push_back(point_of(r, "a polyline_mm point", p));
    }
    const int line = static_cast<int>(polyline->source().begin.line);
    out.cut = fem::swept_polyline(points, point_of(r, "sweep_mm", *sweep),
                                  source + ":" + std::to_string(line));
  } else {
    if (sweep != nullptr) r.fail(*sweep, "sweep_mm goes with polyline_mm, not triangles_mm");
    for (const toml::node& t : array_of(r, "triangles_mm", *triangles)) {
      const toml::array* corners = t.as_array();
      if (corners == nullptr || corners->size() != 3) {
        r.fail(t, "a triangle must be three [x, y, z] corners");
      }
      out.cut.triangles_mm.push_back({point_of(r, "a corner", *corners->get(0)),
                                      point_of(r, "a corner", *corners->get(1)),
                                      point_of(r, "a corner", *corners->get(2))});
    }
  }
  return out;
}

IncisionFile read_incision(const std::string& path) {
  return parse_incision(read_text_file(path), path);
}

}  // namespace hapvox::engine::proxy
