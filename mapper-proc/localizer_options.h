#pragma once
// The localizer's settings (mapper.localize.*, localizer.h): when its pose counts as localized
// against the stored map, and how exactly the stored map is taken.

#include "core/common/expected.h"
#include "core/common/option_fields.h"

namespace evermap::mapper {

struct LocalizerOptions {
  // The pose is localized while its covariance (against the node it was last registered to,
  // with the drift below) stays within these standard deviations: the larger of x and y, and
  // yaw. 0.2 m: the 2-D 95 % radius (2.45 sigma) is 0.5 m, the error at which a localized
  // frame counts as false; 2.5 deg: 1.96 sigma is 5 deg, the same for rotation.
  double max_sigma_m = 0.2;
  double max_sigma_deg = 2.5;
  // Dead reckoning's drift: standard deviations per metre travelled since the last
  // registration applied, added to Δ's covariance in the pose, the map gate's prediction and
  // the bounds above. VO's per-frame covariances are independent, so Δ's grows with the
  // square root of the distance, while VO's error (scale, heading) grows with the distance
  // itself. 1 % and 0.1 deg per m: the smallest that keep about 95 % of the dead-reckoned
  // errors within 2.45 (1.96) sigma on rendered runs without a VO fault (x-y: 5 % and 6 %
  // beyond; docs/results/localization.md, the sweep); a VO fault (a passer-by filling the
  // view, a stretch VO under-estimates) is an outlier no drift rate covers. The distance is
  // the tracker's odometer: the wheels' once any wheel message came, else the tracked path,
  // which moves at VO's keyframe steps (it lags the pose by up to one keyframe).
  double drift_per_m = 0.01;
  double drift_deg_per_m = 0.1;
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
    o.add("drift_per_m", &drift_per_m, "m/m",
          "x-y standard deviation added per metre travelled since the last registration applied")
        .nonNegative();
    o.add("drift_deg_per_m", &drift_deg_per_m, "deg/m",
          "yaw standard deviation added per metre travelled since the last registration applied")
        .nonNegative();
    o.add("map_sigma_m", &map_sigma_m, "m",
          "the stored map's relative position uncertainty between two nodes")
        .positive();
    o.add("map_sigma_deg", &map_sigma_deg, "deg",
          "the stored map's relative rotation uncertainty between two nodes")
        .positive();
  }
};

}  // namespace evermap::mapper
