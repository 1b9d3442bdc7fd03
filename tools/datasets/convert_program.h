#pragma once
// The command line of the data-set converters (tools/datasets/to_lcm.h): evermap-euroc2lcm,
// evermap-kitti2lcm and evermap-tum2lcm differ only in the data set and its options.

namespace evermap::datasets {

enum class Dataset { kEuroc, kKitti, kTumRgbd };

// The converter's main(): parses argv, converts, prints the report. Exit status: 0 done,
// 1 bad input (the message names it), 2 bad command line.
int convertMain(Dataset dataset, int argc, char** argv);

}  // namespace evermap::datasets
