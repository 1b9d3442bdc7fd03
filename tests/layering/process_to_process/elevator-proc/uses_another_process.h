// A process file that reaches into another process: cmake/CheckLayering.cmake must reject it
// (tests/CMakeLists.txt, layering.rejects_a_process_including_another_process); what two
// processes share belongs in core/.
#include "imu-proc/attitude_filter.h"
