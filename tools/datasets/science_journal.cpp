#include "tools/datasets/science_journal.h"

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>

namespace evermap::datasets {

namespace {

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> out(1);
  for (char c : line) {
    if (c == ',') {
      out.emplace_back();
    } else if (c != '\r' && c != '\n') {
      out.back() += c;
    }
  }
  return out;
}

bool parseNumber(const std::string& s, double* v) {
  if (s.empty()) return false;
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size();
}

}  // namespace

std::string ScienceJournalRecording::summary() const {
  char buf[400];
  std::snprintf(
      buf, sizeof buf,
      "%lld rows -> %zu samples: %lld rows completed a sample, %lld updated part of one, "
      "%lld before all three axes were known, %lld after the last sample, %lld linear "
      "acceleration only (not used: gravity removed), %lld empty; %lld axis values "
      "superseded before their sample",
      static_cast<long long>(rows), imu.size(), static_cast<long long>(rows_completing_sample),
      static_cast<long long>(rows_partial), static_cast<long long>(rows_before_first_sample),
      static_cast<long long>(rows_trailing), static_cast<long long>(rows_linear_only),
      static_cast<long long>(rows_empty), static_cast<long long>(values_superseded));
  return buf;
}

Expected<ScienceJournalRecording> readScienceJournalCsv(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) return makeError(file.string(), ": cannot open");
  std::string line;
  if (!std::getline(in, line)) return makeError(file.string(), ": empty file");
  const std::vector<std::string> header = splitCsv(line);
  int col_time = -1, col_linear = -1;
  std::array<int, 3> col_axis = {-1, -1, -1};
  for (int i = 0; i < static_cast<int>(header.size()); ++i) {
    const std::string& h = header[i];
    if (h == "relative_time") col_time = i;
    if (h == "LinearAccelerometerSensor") col_linear = i;
    if (h == "AccX") col_axis[0] = i;
    if (h == "AccY") col_axis[1] = i;
    if (h == "AccZ") col_axis[2] = i;
  }
  if (col_time < 0 || col_axis[0] < 0 || col_axis[1] < 0 || col_axis[2] < 0) {
    return makeError(file.string(), ":1: need the columns relative_time, AccX, AccY, AccZ");
  }
  ScienceJournalRecording rec;
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
  std::array<bool, 3> known = {false, false, false};    // ever seen
  std::array<bool, 3> updated = {false, false, false};  // since the last sample
  int64_t rows_pending = 0;  // rows that updated the sample being assembled
  bool any_sample = false;
  double last_ms = -1e300;
  for (int n = 2; std::getline(in, line); ++n) {
    if (line.empty() || line == "\r") continue;
    ++rec.rows;
    const std::vector<std::string> f = splitCsv(line);
    auto field = [&](int c) -> const std::string& {
      static const std::string kEmpty;
      return c < static_cast<int>(f.size()) ? f[c] : kEmpty;
    };
    double t_ms = 0;
    if (!parseNumber(field(col_time), &t_ms)) {
      return makeError(file.string(), ":", n, ": relative_time is not a number");
    }
    if (t_ms < last_ms) return makeError(file.string(), ":", n, ": relative_time goes backwards");
    last_ms = t_ms;
    bool any_axis = false;
    for (int k = 0; k < 3; ++k) {
      const std::string& s = field(col_axis[k]);
      if (s.empty()) continue;
      double v = 0;
      if (!parseNumber(s, &v)) {
        return makeError(file.string(), ":", n, ": ", header[col_axis[k]], " is not a number");
      }
      if (updated[k]) ++rec.values_superseded;
      value[k] = v;
      known[k] = updated[k] = true;
      any_axis = true;
    }
    if (!any_axis) {
      double v = 0;
      if (col_linear >= 0 && parseNumber(field(col_linear), &v)) {
        ++rec.rows_linear_only;
      } else if (col_linear >= 0 && !field(col_linear).empty()) {
        return makeError(file.string(), ":", n, ": LinearAccelerometerSensor is not a number");
      } else {
        ++rec.rows_empty;
      }
      continue;
    }
    ++rows_pending;
    if (!(known[0] && known[1] && known[2])) continue;
    if (!any_sample) {
      // The first sample: the three axes are known for the first time (whatever came before).
      rec.rows_before_first_sample += rows_pending - 1;
      rows_pending = 1;
      updated = {true, true, true};
    }
    if (updated[0] && updated[1] && updated[2]) {
      ImuSample s;
      s.t_ns = static_cast<int64_t>(std::llround(t_ms * 1e6));
      s.accel_m_s2 = value;
      rec.imu.push_back(s);
      ++rec.rows_completing_sample;
      rec.rows_partial += rows_pending - 1;
      rows_pending = 0;
      updated = {false, false, false};
      any_sample = true;
    }
  }
  if (any_sample) {
    rec.rows_trailing = rows_pending;
  } else {
    rec.rows_before_first_sample = rows_pending;
  }
  return rec;
}

}  // namespace evermap::datasets
