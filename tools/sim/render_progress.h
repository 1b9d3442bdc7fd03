#pragma once
// Progress lines while the image-level simulator renders a session (evermap-sim-render).

#include <functional>

#include "core/common/progress.h"
#include "tools/sim/image_session.h"

namespace evermap::sim {

// A progress callback for ImageSimulator::run that prints a line on stderr at most every
// `period_s` of wall time (data time rendered, frames, rate, time left) and then asks
// `keep_going`.
std::function<bool(double)> withProgressLines(const ImageSimulator& simulator,
                                              std::function<bool(double)> keep_going,
                                              double period_s = kProgressPeriodS);

}  // namespace evermap::sim
