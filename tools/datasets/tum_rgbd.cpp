#include "tools/datasets/tum_rgbd.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "tools/datasets/text_lines.h"

namespace evermap::datasets {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

// Calls `row(words, where)` for every data line; stops at the first error.
template <typename Row>
Status forEachLine(const fs::path& file, Row row) {
  return forEachDataLine(file, [&](const std::string& line, int n) {
    return row(words(line), file.string() + ":" + std::to_string(n));
  });
}

// The rows of a TUM list of `fields` words a line, the first a timestamp in seconds, stamps
// increasing; `fill(words, where, &row)` reads the rest of a line into its row (t_ns is set).
template <typename T, typename Fill>
Expected<std::vector<T>> readStampedRows(const fs::path& file, size_t fields, const char* format,
                                         Fill fill) {
  std::vector<T> out;
  Status s =
      forEachLine(file, [&](const std::vector<std::string>& w, const std::string& where) -> Status {
        T row;
        if (w.size() != fields || !parseSecondsToNs(w[0], &row.t_ns)) {
          return makeError(where, ": expected \"", format, "\"");
        }
        if (Status f = fill(w, where, &row); !f) return f;
        if (!out.empty() && row.t_ns <= out.back().t_ns) {
          return makeError(where, ": timestamp ", w[0], " is not after the previous line's");
        }
        out.push_back(std::move(row));
        return Ok{};
      });
  if (!s) return s.error();
  return out;
}

}  // namespace

Expected<std::vector<TumImageEntry>> readTumImageList(const fs::path& file) {
  return readStampedRows<TumImageEntry>(
      file, 2, "timestamp filename",
      [](const std::vector<std::string>& w, const std::string&, TumImageEntry* e) -> Status {
        e->file = w[1];
        return Ok{};
      });
}

Expected<std::vector<AccelSample>> readTumAccelerometer(const fs::path& file) {
  return readStampedRows<AccelSample>(
      file, 4, "timestamp ax ay az",
      [](const std::vector<std::string>& w, const std::string& where, AccelSample* a) -> Status {
        for (int i = 0; i < 3; ++i) {
          double v = 0.0;
          std::istringstream f(w[static_cast<size_t>(i) + 1]);
          if (!(f >> v) || !f.eof() || !std::isfinite(v)) {
            return makeError(where, ": acceleration '", w[static_cast<size_t>(i) + 1],
                             "' is not a finite number");
          }
          a->accel_m_s2[i] = v;
        }
        return Ok{};
      });
}

std::vector<std::pair<size_t, size_t>> associateByTime(const std::vector<int64_t>& a,
                                                       const std::vector<int64_t>& b,
                                                       int64_t max_difference_ns) {
  struct Candidate {
    int64_t diff;
    size_t i, j;
  };
  std::vector<Candidate> candidates;
  for (size_t i = 0; i < a.size(); ++i) {
    auto j = static_cast<size_t>(std::lower_bound(b.begin(), b.end(), a[i] - max_difference_ns) -
                                 b.begin());
    for (; j < b.size() && b[j] < a[i] + max_difference_ns; ++j) {
      const int64_t d = std::llabs(a[i] - b[j]);
      if (d < max_difference_ns) candidates.push_back({d, i, j});
    }
  }
  // associate.py sorts (diff, a, b) tuples: ties by the stamps, i.e. by index.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
    return x.diff != y.diff ? x.diff < y.diff : (x.i != y.i ? x.i < y.i : x.j < y.j);
  });
  std::vector<bool> used_a(a.size()), used_b(b.size());
  std::vector<std::pair<size_t, size_t>> out;
  for (const Candidate& c : candidates) {
    if (used_a[c.i] || used_b[c.j]) continue;
    used_a[c.i] = used_b[c.j] = true;
    out.emplace_back(c.i, c.j);
  }
  std::sort(out.begin(), out.end());
  return out;
}

Expected<core::CameraCalibration> tumCalibration(const std::string& name) {
  core::CameraCalibration c;
  c.width = 640;
  c.height = 480;
  if (name == "freiburg1") {
    c.fx = 517.3, c.fy = 516.5, c.cx = 318.6, c.cy = 255.3;
    c.distortion_model = core::DistortionModel::kRadTan;
    c.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  } else if (name == "freiburg2") {
    c.fx = 520.9, c.fy = 521.0, c.cx = 325.1, c.cy = 249.7;
    c.distortion_model = core::DistortionModel::kRadTan;
    c.distortion = {0.2312, -0.7849, -0.0033, -0.0001, 0.9172};
  } else if (name == "freiburg3") {
    c.fx = 535.4, c.fy = 539.2, c.cx = 320.1, c.cy = 247.6;
  } else if (name == "ros-default") {
    c.fx = 525.0, c.fy = 525.0, c.cx = 319.5, c.cy = 239.5;
  } else {
    return makeError("TUM calibration '", name,
                     "': not one of freiburg1, freiburg2, freiburg3, ros-default");
  }
  if (Status s = c.validate("TUM " + name); !s) return s.error();
  return c;
}

std::string tumCalibrationNameFor(const fs::path& sequence) {
  std::string name = fs::absolute(sequence).lexically_normal().string();
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  for (const char* n : {"1", "2", "3"}) {
    if (name.find(std::string("freiburg") + n) != std::string::npos ||
        name.find(std::string("fr") + n + "-") != std::string::npos ||
        name.find(std::string("fr") + n + "_") != std::string::npos) {
      return std::string("freiburg") + n;
    }
  }
  return "ros-default";
}

Status TumRgbdOptions::validate() const {
  if (!(max_difference_s > 0.0 && max_difference_s <= 0.05)) {
    return makeError("TUM RGB-D: max_difference_s ", max_difference_s,
                     " is not in (0, 0.05] (the frame message allows 0.05 s)");
  }
  return Ok{};
}

Expected<TumRgbdSequence> readTumRgbdSequence(const fs::path& folder,
                                              const TumRgbdOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  if (!fs::is_directory(folder)) return makeError(folder.string(), ": not a folder");
  TumRgbdSequence seq;
  seq.folder = folder;
  auto color = readTumImageList(folder / "rgb.txt");
  if (!color) return color.error();
  auto depth = readTumImageList(folder / "depth.txt");
  if (!depth) return depth.error();
  seq.color = std::move(*color);
  seq.depth = std::move(*depth);
  std::vector<int64_t> tc, td;
  for (const auto& e : seq.color) tc.push_back(e.t_ns);
  for (const auto& e : seq.depth) td.push_back(e.t_ns);
  seq.frames = associateByTime(tc, td, std::llround(options.max_difference_s * 1e9));
  seq.unassociated_color = static_cast<int64_t>(seq.color.size() - seq.frames.size());
  seq.unassociated_depth = static_cast<int64_t>(seq.depth.size() - seq.frames.size());
  if (seq.frames.empty()) {
    return makeError(folder.string(),
                     ": no color image of rgb.txt has a depth image of "
                     "depth.txt within ",
                     options.max_difference_s, " s");
  }
  if (fs::exists(folder / "groundtruth.txt")) {
    auto gt = readEurocGroundTruth(folder / "groundtruth.txt", PoseFileLayout::kTum);
    if (!gt) return gt.error();
    seq.ground_truth = std::move(*gt);
  }
  if (fs::exists(folder / "accelerometer.txt")) {
    auto acc = readTumAccelerometer(folder / "accelerometer.txt");
    if (!acc) return acc.error();
    seq.accelerometer = std::move(*acc);
  }
  return seq;
}

}  // namespace evermap::datasets
