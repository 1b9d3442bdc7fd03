// A process file that reaches into a tool: cmake/CheckLayering.cmake must reject it
// (tests/CMakeLists.txt, layering.rejects_a_process_including_a_tool).
#include "tools/sim/run.h"
