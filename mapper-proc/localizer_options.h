#pragma once
// The localizer's settings (mapper.localize.*, localizer.h): when its pose counts as localized
// against the stored map, and how exactly the stored map is taken.

#include "core/common/expected.h"
#include "core/common/option_fields.h"

namespace evermap::mapper {

struct LocalizerOptions {
  // The pose is localized while its covariance (against the node it was last registered to)
  // stays within these standard deviations: the larger of x and y, and yaw.
  double max_sigma_m = 1.0;
  double max_sigma_deg = 10.0;
  // ... and while the robot has travelled at most this far (the odometer: wheels, else the
  // tracked path) since the last registration the localizer applied. Odometry covariances
  // grow slower than its errors when VO is overconfident; the distance bounds the drift
  // independently (VO on the rendered building drifts ~1-2 % of the distance).
  double max_dead_reckoning_m = 20.0;
  // The stored map's relative uncertainty between two nodes, standard deviations: the test
  // of two placements on different nodes (a lost robot's) takes the map's relative pose of
  // the two with this covariance.
  double map_sigma_m = 0.05;
  double map_sigma_deg = 1.0;

  void declareOptions(OptionList& o) {
    o.add("max_sigma_m", &max_sigma_m, "m",
          "localized while the pose's x-y standard deviation stays within this")
        .positive();
    o.add("max_sigma_deg", &max_sigma_deg, "deg",
          "localized while the pose's yaw standard deviation stays within this")
        .positive();
    o.add("max_dead_reckoning_m", &max_dead_reckoning_m, "m",
          "localized while the robot travelled at most this far since the last registration "
          "applied")
        .positive();
    o.add("map_sigma_m", &map_sigma_m, "m",
          "the stored map's relative position uncertainty between two nodes")
        .positive();
    o.add("map_sigma_deg", &map_sigma_deg, "deg",
          "the stored map's relative rotation uncertainty between two nodes")
        .positive();
  }
};

}  // namespace evermap::mapper
