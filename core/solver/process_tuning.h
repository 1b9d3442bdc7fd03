#pragma once
// Process-wide settings for a program whose main job is the solver (evermap-solver,
// solver_bench, mapper-proc). Call once from main(); never from library code, because both
// settings affect the whole process.
//  - CHOLMOD (Debian's build) runs OpenMP threads that busy-wait between its parallel
//    regions; with pose-graph sized fronts they only compete with the solver thread on a
//    2-core machine, so OpenMP gets one thread.
//  - Batch steps allocate and free the same large buffers every 100 updates; keeping freed
//    memory in the process avoids the page faults of returning it to the system each time.

namespace evermap::solver {

void tuneProcessForSolver();

}  // namespace evermap::solver
