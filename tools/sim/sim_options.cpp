#include "tools/sim/sim_options.h"

#include "core/common/option_fields.h"

namespace evermap::sim {

Status TrajectoryOptions::validate() const {
  if (file.empty()) return makeError("trajectory.file: needed with mode = trajectory");
  if (!(rate_hz > 0.0)) return makeError("trajectory.rate_hz: must be > 0");
  if (first < 0) return makeError("trajectory.first: must be >= 0");
  if (count < 0 || count == 1) return makeError("trajectory.count: must be 0 (all) or >= 2");
  return Ok{};
}

Status SimOptions::validate() const {
  const std::pair<const char*, Status> parts[] = {{"building.", building.validate()},
                                                  {"patrol.", patrol.validate()},
                                                  {"elevator.", elevator.validate()},
                                                  {"oracle.", oracle.validate()}};
  for (const auto& [prefix, status] : parts) {
    if (!status) return makeError(prefix, status.error().message);
  }
  if (auto s = sensors.validate(); !s) return s;
  if (mode == Mode::kTrajectory) {
    if (auto s = trajectory.validate(); !s) return s;
  }
  return Ok{};
}

std::string SimOptions::toConfigText() const {
  SimOptions copy = *this;
  return OptionList::of(&copy).print();
}

std::string whereIn(const KeyValueFile& file, const std::string& key) {
  const KeyValueFile::Entry* e = file.find(key);
  return e ? e->origin : file.name() + " (default value)";
}

Expected<SimOptions> loadSimOptions(const KeyValueFile& file) {
  SimOptions o;
  KeyValueFile own = file;
  // meta.*: what the simulator wrote about a run; mapper.*: the mapper's options, which a
  // run's config may carry (evermap-mapper-run reads them, KeyValueFile::extract).
  own.extract("meta.");
  own.extract("mapper.");
  if (Status s = OptionList::of(&o).load(own); !s) return s.error();
  // An empty string would make the trajectory file the config folder itself.
  if (!o.trajectory.file.empty() && std::filesystem::path(o.trajectory.file).is_relative()) {
    o.trajectory.file = (file.folder() / o.trajectory.file).lexically_normal().string();
  }
  if (auto s = o.validate(); !s) {
    const std::string& m = s.error().message;
    return makeError(whereIn(file, m.substr(0, m.find(':'))), ": ", m);
  }
  return o;
}

}  // namespace evermap::sim
