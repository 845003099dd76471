#pragma once
// hapvox's public C++ API, all of it (docs/api.md). Standard C++20 only: no OpenVDB, Eigen or
// HDF5 header comes in with it. Link hapvox::haptics (it brings hapvox::engine).

#include "hapvox/device.h"
#include "hapvox/error.h"
#include "hapvox/loop.h"
#include "hapvox/model.h"
#include "hapvox/replay.h"
#include "hapvox/session.h"
#include "hapvox/trace.h"
#include "hapvox/version.h"
#include "hapvox/volume.h"
