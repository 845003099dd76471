#include "engine/proxy/tetgen_files.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "engine/errors.h"

namespace hapvox::engine::proxy {
namespace {

std::ofstream open_for_writing(const std::string& path) {
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw InputError(path, "cannot create file");
  out.precision(17);
  return out;
}

void finish(std::ofstream& out, const std::string& path) {
  out.close();
  if (!out) throw InputError(path, "failed to write");
}

// The non-comment lines of a TetGen file, split into tokens, with their line numbers.
class TokenLines {
 public:
  explicit TokenLines(const std::string& path) : path_(path), in_(path) {
    if (!in_) throw InputError(path, "cannot open file");
  }

  // The next line with a token on it; false at the end of the file.
  bool next(std::vector<std::string>& tokens) {
    std::string line;
    while (std::getline(in_, line)) {
      ++number_;
      const std::size_t hash = line.find('#');
      if (hash != std::string::npos) line.resize(hash);
      std::istringstream words(line);
      tokens.clear();
      for (std::string w; words >> w;) tokens.push_back(w);
      if (!tokens.empty()) return true;
    }
    return false;
  }

  InputError error(const std::string& problem) const {
    return InputError(path_ + ":" + std::to_string(number_), problem);
  }

  template <typename T>
  T number(const std::string& token, const char* what) const {
    T value{};
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (ec != std::errc() || end != token.data() + token.size()) {
      throw error(std::string("expected ") + what + ", got '" + token + "'");
    }
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(value)) throw error(std::string(what) + " is not finite");
    }
    return value;
  }

  void expect_line(std::vector<std::string>& tokens, const char* what) {
    if (!next(tokens)) throw InputError(path_, std::string("ends before ") + what);
  }

 private:
  std::string path_;
  std::ifstream in_;
  int number_ = 0;
};

}  // namespace

void write_tetgen_mesh(const std::string& prefix, const fem::TetMesh& mesh) {
  const std::string node_path = prefix + ".node";
  std::ofstream node = open_for_writing(node_path);
  node << "# hapvox proxy mesh: rest positions (mm)\n" << mesh.vertex_count() << " 3 0 0\n";
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    node << v << ' ' << mesh.rest_mm(0, v) << ' ' << mesh.rest_mm(1, v) << ' ' << mesh.rest_mm(2, v)
         << '\n';
  }
  finish(node, node_path);
  const std::string ele_path = prefix + ".ele";
  std::ofstream ele = open_for_writing(ele_path);
  ele << "# hapvox proxy mesh: tets, region attribute = label\n" << mesh.tet_count() << " 4 1\n";
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const fem::Tet& tet = mesh.tets[t];
    ele << t << ' ' << tet[0] << ' ' << tet[1] << ' ' << tet[2] << ' ' << tet[3] << ' '
        << mesh.labels[t] << '\n';
  }
  finish(ele, ele_path);
}

int write_tetgen_surface(const std::string& prefix, const fem::TetMesh& mesh) {
  // Every face with the tets on its sides: one tet (the outer surface) or two of different
  // labels (a label boundary) make a facet.
  std::map<std::array<std::int32_t, 3>, std::vector<int>> faces;
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  for (int t = 0; t < mesh.tet_count(); ++t) {
    for (const auto& f : kFace) {
      std::array<std::int32_t, 3> key{mesh.tets[t][f[0]], mesh.tets[t][f[1]], mesh.tets[t][f[2]]};
      std::sort(key.begin(), key.end());
      faces[key].push_back(t);
    }
  }
  std::vector<std::pair<std::array<std::int32_t, 3>, int>> facets;  // vertices, marker
  std::map<std::int32_t, std::int32_t> renumbered;
  for (const auto& [key, tets] : faces) {
    const bool outer = tets.size() == 1;
    if (!outer && mesh.labels[tets[0]] == mesh.labels[tets[1]]) continue;
    facets.emplace_back(key, outer ? 1 : 2);
    for (const std::int32_t v : key) renumbered.emplace(v, 0);
  }
  std::int32_t next = 0;
  for (auto& [v, index] : renumbered) index = next++;
  const std::string path = prefix + ".smesh";
  std::ofstream out = open_for_writing(path);
  out << "# hapvox proxy mesh: outer surface (marker 1) and label boundaries (marker 2)\n"
      << renumbered.size() << " 3 0 0\n";
  for (const auto& [v, index] : renumbered) {
    out << index << ' ' << mesh.rest_mm(0, v) << ' ' << mesh.rest_mm(1, v) << ' '
        << mesh.rest_mm(2, v) << '\n';
  }
  out << facets.size() << " 1\n";
  for (const auto& [key, marker] : facets) {
    out << "3 " << renumbered[key[0]] << ' ' << renumbered[key[1]] << ' ' << renumbered[key[2]]
        << ' ' << marker << '\n';
  }
  out << "0\n0\n";  // no holes, no regions
  finish(out, path);
  return static_cast<int>(facets.size());
}

fem::TetMesh read_tetgen_mesh(const std::string& prefix) {
  fem::TetMesh mesh;
  std::vector<std::string> tokens;
  // .node
  const std::string node_path = prefix + ".node";
  TokenLines node(node_path);
  node.expect_line(tokens, "its header");
  if (tokens.size() < 2) throw node.error("expected '<points> 3 <attributes> <markers>'");
  const auto points = node.number<std::int64_t>(tokens[0], "a point count");
  if (node.number<int>(tokens[1], "the dimension") != 3)
    throw node.error("the dimension must be 3");
  if (points <= 0 || points > (std::int64_t{1} << 31) - 1) {
    throw node.error("the point count must lie in [1, 2^31)");
  }
  const int attributes = tokens.size() > 2 ? node.number<int>(tokens[2], "an attribute count") : 0;
  const int markers = tokens.size() > 3 ? node.number<int>(tokens[3], "a marker count") : 0;
  if (attributes < 0 || attributes > 1000 || markers < 0 || markers > 1) {
    throw node.error("bad attribute or marker count");
  }
  // Grown line by line: a header's count alone must not allocate (a corrupt one could ask
  // for gigabytes).
  std::vector<double> coordinates;
  std::int64_t base = 0;
  for (std::int64_t p = 0; p < points; ++p) {
    node.expect_line(tokens, "its last point");
    if (tokens.size() != static_cast<std::size_t>(4 + attributes + markers)) {
      throw node.error("expected " + std::to_string(4 + attributes + markers) + " values, got " +
                       std::to_string(tokens.size()));
    }
    const auto index = node.number<std::int64_t>(tokens[0], "a point index");
    if (p == 0) base = index;
    if (p == 0 && base != 0 && base != 1)
      throw node.error("the first point's index must be 0 or 1");
    if (index != base + p) throw node.error("points must be numbered in order");
    for (int a = 0; a < 3; ++a) {
      coordinates.push_back(node.number<double>(tokens[1 + a], "a coordinate"));
    }
  }
  mesh.rest_mm = Eigen::Map<const Eigen::Matrix3Xd>(coordinates.data(), 3, points);
  // .ele
  const std::string ele_path = prefix + ".ele";
  TokenLines ele(ele_path);
  ele.expect_line(tokens, "its header");
  if (tokens.size() < 2) throw ele.error("expected '<tets> 4 <region attribute>'");
  const auto tets = ele.number<std::int64_t>(tokens[0], "a tet count");
  if (ele.number<int>(tokens[1], "nodes per tet") != 4) {
    throw ele.error("only 4-node tets are read (no -o2)");
  }
  if (tets <= 0 || tets > (std::int64_t{1} << 31) - 1)
    throw ele.error("the tet count must lie in [1, 2^31)");
  const int regions =
      tokens.size() > 2 ? ele.number<int>(tokens[2], "a region attribute count") : 0;
  if (regions < 0 || regions > 1) throw ele.error("the region attribute count must be 0 or 1");
  for (std::int64_t t = 0; t < tets; ++t) {
    ele.expect_line(tokens, "its last tet");
    if (tokens.size() != static_cast<std::size_t>(5 + regions)) {
      throw ele.error("expected " + std::to_string(5 + regions) + " values, got " +
                      std::to_string(tokens.size()));
    }
    fem::Tet tet{};
    for (int k = 0; k < 4; ++k) {
      const auto v = ele.number<std::int64_t>(tokens[1 + k], "a point index") - base;
      if (v < 0 || v >= points)
        throw ele.error("point " + tokens[1 + k] + " is not in " + node_path);
      tet[k] = static_cast<std::int32_t>(v);
    }
    const double volume =
        fem::signed_volume_mm3(mesh.rest_mm.col(tet[0]), mesh.rest_mm.col(tet[1]),
                               mesh.rest_mm.col(tet[2]), mesh.rest_mm.col(tet[3]));
    if (!(std::abs(volume) > 0.0)) throw ele.error("a tet with no volume");
    if (volume < 0) std::swap(tet[2], tet[3]);  // TetGen's orientation is the other way round
    mesh.tets.push_back(tet);
    std::int32_t label = 0;
    if (regions == 1) {
      const double attribute = ele.number<double>(tokens[5], "a region attribute");
      if (attribute != std::round(attribute) || std::abs(attribute) > (1 << 24)) {
        throw ele.error("the region attribute must be an integer label");
      }
      label = static_cast<std::int32_t>(attribute);
    }
    mesh.labels.push_back(label);
  }
  return mesh;
}

}  // namespace hapvox::engine::proxy
