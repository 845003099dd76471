#include "tools/relabel.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <set>

#include "engine/errors.h"

namespace hapvox::cli {
namespace {

// The whole of `text` as a label in [0, kMaxLabel], or nullopt.
std::optional<engine::labels::Label> parse_label(std::string_view text) {
  engine::labels::Label label = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), label);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || label < 0 ||
      label > engine::labels::kMaxLabel) {
    return std::nullopt;
  }
  return label;
}

}  // namespace

Relabel parse_relabel(const std::string& text) {
  const auto bad = [&](const std::string& what) {
    return InputError("--relabel",
                      what + " in '" + text + "' (expected T_S:FROM=TO, e.g. 0.5:4=2)");
  };
  const std::size_t colon = text.find(':');
  const std::size_t equals = text.find('=', colon == std::string::npos ? 0 : colon);
  if (colon == std::string::npos || equals == std::string::npos) throw bad("no ':' or '='");
  Relabel relabel;
  const std::string time = text.substr(0, colon);
  const auto [end, ec] = std::from_chars(time.data(), time.data() + time.size(), relabel.time_s);
  if (time.empty() || ec != std::errc() || end != time.data() + time.size() ||
      !std::isfinite(relabel.time_s) || relabel.time_s < 0.0) {
    throw bad("the time must be a number of seconds >= 0");
  }
  const auto from = parse_label(std::string_view(text).substr(colon + 1, equals - colon - 1));
  const auto to = parse_label(std::string_view(text).substr(equals + 1));
  if (!from || !to) {
    throw bad("labels must be integers in [0, " + std::to_string(engine::labels::kMaxLabel) + "]");
  }
  if (*from == *to) throw bad("FROM and TO are the same label");
  relabel.from = *from;
  relabel.to = *to;
  return relabel;
}

std::vector<haptics::LabelChange> label_changes(std::vector<Relabel> relabels,
                                                const ProxyInputs& inputs, std::size_t ticks,
                                                double rate_hz) {
  std::stable_sort(relabels.begin(), relabels.end(),
                   [](const Relabel& a, const Relabel& b) { return a.time_s < b.time_s; });
  std::vector<haptics::LabelChange> changes;
  engine::labels::LabelMap labels = inputs.labels;
  const double duration_s = static_cast<double>(ticks) / rate_hz;
  for (const Relabel& r : relabels) {
    // Compared as a double first: llround of a time far past the end is out of range.
    const double tick_d = std::round(r.time_s * rate_hz);
    if (!(tick_d < static_cast<double>(ticks))) {
      char what[160];
      std::snprintf(what, sizeof what, "%g s is past the trace's end (%g s)", r.time_s, duration_s);
      throw InputError("--relabel", what);
    }
    const auto tick = static_cast<std::int64_t>(tick_d);
    std::vector<engine::labels::Label>& data = labels.mutable_data();
    if (std::find(data.begin(), data.end(), r.from) == data.end()) {
      std::string present;
      for (const auto& [label, count] : labels.voxel_counts()) {
        present += (present.empty() ? "" : ", ") + std::to_string(label);
      }
      char at[64];
      std::snprintf(at, sizeof at, " is not in the labels at %g s (they hold ", r.time_s);
      throw InputError("--relabel", "label " + std::to_string(r.from) + at + present + ")");
    }
    std::replace(data.begin(), data.end(), r.from, r.to);
    engine::labels::check_labels_have_materials(labels, inputs.materials);
    // What the rebuild would refuse, refused now: a fixed region naming a label gone, and
    // labels that fix nothing (a free body).
    engine::labels::resolve_fixed_regions(inputs.materials, labels);
    if (inputs.materials.fixed_regions.empty()) {
      const std::set<engine::labels::Label> fixed = inputs.materials.fixed_labels();
      if (std::none_of(data.begin(), data.end(),
                       [&](engine::labels::Label l) { return fixed.count(l) > 0; })) {
        char at[96];
        std::snprintf(at, sizeof at, "after the change at %g s nothing is fixed (a free body)",
                      r.time_s);
        throw InputError("--relabel", at);
      }
    }
    auto changed = std::make_shared<const engine::labels::LabelMap>(labels);
    auto materials = std::make_shared<const engine::labels::Materials>(inputs.materials);
    changes.push_back(haptics::LabelChange{
        tick, "label " + std::to_string(r.from) + " -> " + std::to_string(r.to),
        [changed, materials, mesh = inputs.mesh] {
          return engine::proxy::build_proxy_mesh(*changed, *materials, mesh);
        }});
  }
  return changes;
}

}  // namespace hapvox::cli
