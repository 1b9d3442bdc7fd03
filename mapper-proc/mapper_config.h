#pragma once
// MapperOptions from `key = value` settings (core/common/key_value_file.h): "mapper." and the
// keys MapperOptions::declareOptions declares, with tracker.*, solver.* and floor_gate.* for
// the nested ones, e.g.
//   mapper.map_gate = 0            mapper.fuse_active_registration = false
//   mapper.loop_kernel = dcs:20    mapper.solver.batch_every = 50
// (kernels as parseRobustKernel reads them; mapper.solver.method = gn or dogleg).
// evermap-mapper-run reads them beside the simulator's keys (KeyValueFile::extract parts them),
// evermap-mapper-proc from a file of its own; both take --set. full_graph and
// tracker.body_T_cam are the programs' business, not settings.

#include "core/common/expected.h"
#include "core/common/key_value_file.h"
#include "mapper-proc/mapper.h"

namespace evermap::mapper {

// Reads every key of `file` (all must be mapper.* keys) into `options` (missing keys keep
// their values) and validates the result. Errors name the file and line of the bad value, or
// the unknown key.
Status readMapperOptions(const KeyValueFile& file, MapperOptions* options);

// Every mapper.* setting of `options` as `key = value` lines (a config readMapperOptions reads
// back to the same options).
std::string printMapperOptions(const MapperOptions& options);

}  // namespace evermap::mapper
