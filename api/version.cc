#include "hapvox/version.h"

namespace hapvox {

const char* version() noexcept { return HAPVOX_VERSION_STRING; }

}  // namespace hapvox
