#include "tools/sim/render_progress.h"

#include <memory>
#include <utility>

#include "core/common/progress.h"

namespace evermap::sim {

std::function<bool(double)> withProgressLines(const ImageSimulator& simulator,
                                              std::function<bool(double)> keep_going,
                                              double period_s) {
  const double duration_s =
      1e-6 * static_cast<double>(simulator.endUtime() - simulator.startUtime());
  auto reporter =
      std::make_shared<ProgressReporter>("evermap-sim-render", "frames", printToStderr, period_s);
  auto frames = std::make_shared<int64_t>(0);
  return [=, keep_going = std::move(keep_going)](double fraction) {
    reporter->update(Progress{fraction * duration_s, duration_s, -1.0, ++*frames, -1});
    return keep_going ? keep_going(fraction) : true;
  };
}

}  // namespace evermap::sim
