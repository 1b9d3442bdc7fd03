// evermap-tum2lcm: a TUM RGB-D sequence to an LCM log (core/datasets/to_lcm.h).
#include "tools/dataset2lcm/convert_main.h"

int main(int argc, char** argv) { return evermap::datasets::convertMain(evermap::datasets::Dataset::kTumRgbd, argc, argv); }
