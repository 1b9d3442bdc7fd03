// A core file that includes a process: cmake/CheckLayering.cmake must reject it.
#include "mapper-proc/mapper.h"
