#pragma once
// Direction cosines: the world (LPS) direction of each index axis, as the columns of an
// orthonormal matrix (engine/density_field.h). Checks and the three-letter codes ITK and
// MetaImage name them by.

#include <string>

#include "engine/density_field.h"

namespace hapvox::engine::io {

/// "" when `direction` is orthonormal (columns of unit length, at right angles, to 1e-4,
/// either handedness), else what is wrong, e.g. "not orthonormal (a sheared or scaled
/// grid): column 2 has length 1.5".
std::string direction_problem(const Mat3d& direction);

/// ITK's orientation code: for each index axis the side it comes from, R/L (x), A/P (y),
/// I/S (z) of the axis's largest component. The identity in LPS is "RAI".
std::string orientation_code(const Mat3d& direction);

/// True for three letters naming three different axes ("RAI", "lps") or "???".
bool orientation_code_valid(const std::string& code);

}  // namespace hapvox::engine::io
