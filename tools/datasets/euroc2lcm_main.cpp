// evermap-euroc2lcm: an EuRoC ASL folder to an LCM log (tools/datasets/to_lcm.h).
#include "tools/datasets/convert_program.h"

int main(int argc, char** argv) {
  return evermap::datasets::convertMain(evermap::datasets::Dataset::kEuroc, argc, argv);
}
