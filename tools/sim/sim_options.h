#pragma once
// Every setting of a measurement-level simulation run, loadable from a `key = value` file
// (config/sim-*.conf) and printable back into one (the sidecar written beside each log).
// Keys are `section.field`, e.g. `vo.rate_hz`; `seed` and `mode` have no section. Keys that
// start with `meta.` are written by the simulator into sidecars and ignored when read.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/key_value_file.h"
#include "tools/sim/building.h"
#include "tools/sim/patrol.h"
#include "tools/sim/registration_oracle.h"
#include "tools/sim/session_generator.h"

namespace evermap {
class OptionList;
}

namespace evermap::sim {

// mode = trajectory: drive along a recorded trajectory instead of patrolling a building.
struct TrajectoryOptions {
  std::string file;       // KITTI odometry poses (12 numbers per line); relative to the config
  double rate_hz = 10.0;  // of the poses in the file
  int first = 0;          // first pose used
  int count = 0;          // poses used; 0: to the end of the file

  Status validate() const;
};

struct OutputOptions {
  bool split_sessions = true;  // one log per session; else one log for the whole run
  bool tum = true;             // ground truth in TUM format beside each log
};

struct SimOptions {
  enum class Mode { kBuilding, kTrajectory };
  uint64_t seed = 1;
  Mode mode = Mode::kBuilding;
  BuildingOptions building;
  PatrolOptions patrol;
  ElevatorOptions elevator;
  SensorOptions sensors;
  OracleOptions oracle;
  TrajectoryOptions trajectory;
  OutputOptions output;

  // Every key, its unit, range and doc (sim_option_list.cpp; core/common/option_fields.h).
  void declareOptions(OptionList& o);
  // The rules that tie keys together. Messages start with the dotted key ("vo.rate_hz: ...").
  Status validate() const;
  // Every setting as `key = value  # unit` lines, in a fixed order (readable back).
  std::string toConfigText() const;
};

// Reads a configuration: unknown keys, malformed values, values outside their range and invalid
// settings are errors that name the file and line (meta.* and mapper.* keys are left to others).
// Relative trajectory files are resolved against the file's folder.
Expected<SimOptions> loadSimOptions(const KeyValueFile& file);

// `load` (loadSimOptions, loadImageSimOptions) of a program's --config `path` with its
// `sets`, the `key=value` arguments of its `option` ("--set"). Errors: the file's or `load`'s.
template <typename Options>
Expected<Options> loadConfig(Expected<Options> (*load)(const KeyValueFile&),
                             const std::filesystem::path& path,
                             const std::vector<std::string>& sets, const std::string& option) {
  auto file = KeyValueFile::load(path, sets, option);
  if (!file) return file.error();
  return load(*file);
}

// Where `file` sets `key` ("sim.conf:12"), else "sim.conf (default value)": the place an
// error of validate() points at.
std::string whereIn(const KeyValueFile& file, const std::string& key);

}  // namespace evermap::sim
