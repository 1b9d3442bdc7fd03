// evermap-tum2lcm: a TUM RGB-D sequence to an LCM log (tools/datasets/to_lcm.h).
#include "tools/datasets/convert_program.h"

int main(int argc, char** argv) {
  return evermap::datasets::convertMain(evermap::datasets::Dataset::kTumRgbd, argc, argv);
}
