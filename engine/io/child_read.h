#pragma once
// Reading a volume in a child process, for readers built on a library that aborts or crashes
// on some corrupt files: Debian's GDCM keeps its assertions on, and a truncated DICOM file
// trips them. The child takes the crash; the caller gets one clear InputError.

#include <cstdint>
#include <string>

#include "engine/io/raw_volume.h"

namespace hapvox::engine::io {

/// Runs `read(path)` in a forked child process and returns the volume it read, sent back
/// through a pipe. An InputError thrown in the child is thrown again here with its source and
/// problem. Throws InputError(path, "<library> crashed reading it (...)") when the child dies
/// of a signal or exits without an answer, and InputError(path, ...) when no child can be
/// started. The child may map `budget_bytes` beyond what it has mapped at the fork (its
/// address space is capped there): past that, InputError(path, "<library> needed more than
/// N MB reading it: a corrupt file"), or the crash above where the allocator aborts (a
/// sanitizer's). Call it before the program starts threads of its own where possible: a
/// forked child has only the calling thread, and the reader must not need the others.
RawVolume read_in_child_process(const std::string& path, RawVolume (*read)(const std::string&),
                                const std::string& library, std::uint64_t budget_bytes);

}  // namespace hapvox::engine::io
