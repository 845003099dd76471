#pragma once
// Volume input and output, one file per format under engine/io/ behind one table
// (engine/io/formats.h): NRRD (engine/io/nrrd.h), OpenVDB (engine/io/vdb.h), the intensity
// -> density mapping (engine/io/intensity.h) and the synthetic generators
// (engine/io/generators.h). This header gathers them under hapvox::engine.
//
// Every user-facing failure throws hapvox::InputError naming the file and the problem.

#include "engine/io/formats.h"
#include "engine/io/generators.h"
#include "engine/io/intensity.h"
#include "engine/io/nrrd.h"
#include "engine/io/raw_volume.h"
#include "engine/io/vdb.h"

namespace hapvox::engine {

using io::dense_intensity;
using io::generate_volume;
using io::IntensityMapping;
using io::is_generator_spec;
using io::load_volume;
using io::map_to_density;
using io::nrrd_data_file;
using io::otsu_threshold;
using io::RawVolume;
using io::read_nrrd;
using io::read_scalar_volume;
using io::read_vdb;
using io::write_nrrd;
using io::write_vdb;

}  // namespace hapvox::engine
