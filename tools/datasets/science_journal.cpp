#include "tools/datasets/science_journal.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "core/messages/convert.h"

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

// The columns read: time (ms), the three accelerometer axes, the linear accelerometer.
struct Columns {
  int time = -1, linear = -1;
  std::array<int, 3> axis = {-1, -1, -1};
};

Expected<Columns> columnsOf(const std::vector<std::string>& header,
                            const std::filesystem::path& file) {
  Columns c;
  for (int i = 0; i < static_cast<int>(header.size()); ++i) {
    const std::string& h = header[i];
    if (h == "relative_time") c.time = i;
    if (h == "LinearAccelerometerSensor") c.linear = i;
    if (h == "AccX") c.axis[0] = i;
    if (h == "AccY") c.axis[1] = i;
    if (h == "AccZ") c.axis[2] = i;
  }
  if (c.time < 0 || c.axis[0] < 0 || c.axis[1] < 0 || c.axis[2] < 0) {
    return makeError(file.string(), ":1: need the columns relative_time, AccX, AccY, AccZ");
  }
  return c;
}

// Samples from rows that each give some of the axes: a sample at the row that completes an
// update of all three since the last sample.
class SampleAssembly {
 public:
  SampleAssembly(const std::filesystem::path& file, const std::vector<std::string>& header,
                 const Columns& columns)
      : file_(file), header_(header), c_(columns) {}

  // Data line `n` of the file, split.
  Status row(int n, const std::vector<std::string>& f) {
    ++rec_.rows;
    auto field = [&](int c) -> const std::string& {
      static const std::string kEmpty;
      return c < static_cast<int>(f.size()) ? f[c] : kEmpty;
    };
    double t_ms = 0;
    if (!parseNumber(field(c_.time), &t_ms)) {
      return makeError(file_.string(), ":", n, ": relative_time is not a number");
    }
    if (t_ms < last_ms_) return makeError(file_.string(), ":", n, ": relative_time goes backwards");
    last_ms_ = t_ms;
    bool any_axis = false;
    for (int k = 0; k < 3; ++k) {
      const std::string& s = field(c_.axis[k]);
      if (s.empty()) continue;
      double v = 0;
      if (!parseNumber(s, &v)) {
        return makeError(file_.string(), ":", n, ": ", header_[c_.axis[k]], " is not a number");
      }
      if (updated_[k]) ++rec_.values_superseded;
      value_[k] = v;
      known_[k] = updated_[k] = true;
      any_axis = true;
    }
    if (any_axis) {
      axesUpdated(t_ms);
      return Ok{};
    }
    double v = 0;
    if (c_.linear >= 0 && parseNumber(field(c_.linear), &v)) {
      ++rec_.rows_linear_only;
    } else if (c_.linear >= 0 && !field(c_.linear).empty()) {
      return makeError(file_.string(), ":", n, ": LinearAccelerometerSensor is not a number");
    } else {
      ++rec_.rows_empty;
    }
    return Ok{};
  }

  ScienceJournalRecording finish() {
    if (any_sample_) {
      rec_.rows_trailing = rows_pending_;
    } else {
      rec_.rows_before_first_sample = rows_pending_;
    }
    return std::move(rec_);
  }

 private:
  void axesUpdated(double t_ms) {
    ++rows_pending_;
    if (!(known_[0] && known_[1] && known_[2])) return;
    if (!any_sample_) {
      // The first sample: the three axes are known for the first time (whatever came before).
      rec_.rows_before_first_sample += rows_pending_ - 1;
      rows_pending_ = 1;
      updated_ = {true, true, true};
    }
    if (!(updated_[0] && updated_[1] && updated_[2])) return;
    imu::ImuSample s;
    s.utime = messages::utimeFromNs(std::llround(t_ms * 1e6));
    s.accel_m_s2 = value_;
    rec_.imu.push_back(s);
    ++rec_.rows_completing_sample;
    rec_.rows_partial += rows_pending_ - 1;
    rows_pending_ = 0;
    updated_ = {false, false, false};
    any_sample_ = true;
  }

  const std::filesystem::path& file_;
  const std::vector<std::string>& header_;
  const Columns c_;
  ScienceJournalRecording rec_;
  Eigen::Vector3d value_ = Eigen::Vector3d::Zero();
  std::array<bool, 3> known_ = {false, false, false};    // ever seen
  std::array<bool, 3> updated_ = {false, false, false};  // since the last sample
  int64_t rows_pending_ = 0;  // rows that updated the sample being assembled
  bool any_sample_ = false;
  double last_ms_ = -1e300;
};

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
  auto columns = columnsOf(header, file);
  if (!columns) return columns.error();
  SampleAssembly assembly(file, header, *columns);
  for (int n = 2; std::getline(in, line); ++n) {
    if (line.empty() || line == "\r") continue;
    if (Status s = assembly.row(n, splitCsv(line)); !s) return s.error();
  }
  return assembly.finish();
}

}  // namespace evermap::datasets
