#pragma once
// H3D API DeviceLog text logs as traces. H3D's DeviceLog node (HAPI::DeviceLog with
// logBinary FALSE) writes one header row of field names separated by spaces, e.g.
//
//   TIME POSITION ORIENTATION VELOCITY BUTTONS FORCE TORQUE
//
// then one row per log entry with each field's values separated by spaces: TIME one number
// (seconds from the log's start), POSITION/VELOCITY/FORCE/TORQUE and their RAW_ variants
// three (HAPI's units: metres, m/s, N, N m), ORIENTATION and RAW_ORIENTATION four (a
// rotation as axis x y z and angle in radians), BUTTONS and TIMESTAMP one. The trace takes
// TIME, POSITION (else RAW_POSITION) in metres, made millimetres, and ORIENTATION (else
// RAW_ORIENTATION, with RAW_POSITION) as the stylus orientation. Binary logs (logBinary
// TRUE) are refused with one line. docs/formats.md, "Traces".

#include <string>
#include <string_view>

#include "haptics/trace.h"

namespace hapvox::haptics {

/// True when the first line that is not blank is a DeviceLog header: names of DeviceLog
/// fields (TIME among them) separated by white space. False for a file that cannot be read.
bool is_h3d_device_log(const std::string& path);

/// The header row's test, on its text.
bool is_h3d_device_log_header(std::string_view line);

/// Reads a DeviceLog text log. Throws InputError(path, "line 7: ...") for a bad file.
Trace read_h3d_device_log(const std::string& path);

/// Parses a DeviceLog's text; `source` names it in errors.
Trace parse_h3d_device_log(const std::string& text, const std::string& source);

}  // namespace hapvox::haptics
