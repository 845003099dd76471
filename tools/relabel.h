#pragma once
// `hapvox replay --model fem --relabel T_S:FROM=TO`: the labels change during the run (from
// T_S seconds after the trace's first sample, the voxels of label FROM take label TO), and
// the FEM stage rebuilds its mesh in the background (haptics/fem_remesh.h). Repeatable; each
// change applies to the labels the ones before it left.

#include <memory>
#include <string>
#include <vector>

#include "haptics/fem_remesh.h"
#include "tools/fem_options.h"

namespace hapvox::cli {

struct Relabel {
  double time_s = 0;
  engine::labels::Label from = 0;
  engine::labels::Label to = 0;
};

/// "T_S:FROM=TO" (e.g. "0.5:4=2"). Throws InputError("--relabel", ...) naming what is wrong.
Relabel parse_relabel(const std::string& text);

/// The label changes of `relabels` (any order) on `inputs`' labels, for a run of `ticks`
/// ticks at `rate_hz`. Every change is made and checked now, so that a bad one stops the run
/// before it starts: InputError("--relabel", ...) for a time outside the trace or a FROM
/// label the labels do not hold at that point, and the materials file's error for a TO label
/// with no material. Each change's build meshes its labels with `inputs`' options.
std::vector<haptics::LabelChange> label_changes(std::vector<Relabel> relabels,
                                                const ProxyInputs& inputs, std::size_t ticks,
                                                double rate_hz);

}  // namespace hapvox::cli
