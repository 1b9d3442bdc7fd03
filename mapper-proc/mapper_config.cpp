#include "mapper-proc/mapper_config.h"

#include <string>

namespace evermap::mapper {

Status readMapperOptions(const KeyValueFile& file, MapperOptions* options) {
  if (Status s = OptionList::of(options, "mapper.").load(file); !s) return s;
  if (Status s = options->validate(); !s) return makeError(file.name(), ": ", s.error().message);
  return Ok{};
}

std::string printMapperOptions(const MapperOptions& options) {
  MapperOptions copy = options;
  return OptionList::of(&copy, "mapper.").print();
}

}  // namespace evermap::mapper
