#include "core/solver/process_tuning.h"

#include <dlfcn.h>
#include <malloc.h>

namespace evermap::solver {

void tuneProcessForSolver() {
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  // libgomp is loaded with CHOLMOD; look the setter up rather than linking OpenMP ourselves.
  using SetThreads = void (*)(int);
  if (auto set = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "omp_set_num_threads"))) set(1);
}

}  // namespace evermap::solver
