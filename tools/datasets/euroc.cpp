#include "tools/datasets/euroc.h"

#include <charconv>
#include <cmath>
#include <fstream>

#include "core/messages/convert.h"
#include "tools/datasets/text_lines.h"

namespace evermap::datasets {
namespace {

// Parses the leading integer of a line (nanosecond stamps do not fit a double exactly).
bool parseStamp(const std::string& field, int64_t* out) {
  const char* b = field.data();
  while (*b == ' ') ++b;
  const char* e = field.data() + field.size();
  auto [p, ec] = std::from_chars(b, e, *out);
  return ec == std::errc() && (p == e || *p == ',' || *p == ' ' || *p == '\r');
}

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : line) {
    if (c == '\r') continue;
    if (c == sep) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

}  // namespace

// "1403715274.30214" -> ns, exactly: seconds since the epoch do not fit a double's 53 bits
// at nanosecond resolution, so the whole and fractional parts are read as integers. Fields
// with an exponent (KITTI times.txt: "1.038752e-01") go through a double.
bool parseSecondsToNs(const std::string& field, int64_t* out) {
  if (field.empty()) return false;
  if (field.find_first_of("eE") != std::string::npos) {
    double s = 0.0;
    auto [p, ec] = std::from_chars(field.data(), field.data() + field.size(), s);
    if (ec != std::errc() || p != field.data() + field.size() || !std::isfinite(s) ||
        std::abs(s) > 9.2e9) {
      return false;
    }
    *out = std::llround(s * 1e9);
    return true;
  }
  const bool negative = field[0] == '-';
  const std::string body = negative ? field.substr(1) : field;
  const size_t dot = body.find('.');
  const std::string whole = body.substr(0, dot);
  const std::string frac = dot == std::string::npos ? "" : body.substr(dot + 1);
  if (whole.empty() && frac.empty()) return false;
  int64_t s = 0;
  if (!whole.empty()) {
    auto [p, ec] = std::from_chars(whole.data(), whole.data() + whole.size(), s);
    if (ec != std::errc() || p != whole.data() + whole.size() || s > 9200000000LL) return false;
  }
  int64_t frac_ns = 0;
  int64_t digit_value = 100000000;  // the first fractional digit is worth 1e8 ns
  for (char c : frac) {
    if (c < '0' || c > '9') return false;
    frac_ns += (c - '0') * digit_value;  // digits beyond the 9th (sub-ns) are dropped
    digit_value /= 10;
  }
  const int64_t ns = s * 1000000000LL + frac_ns;
  *out = negative ? -ns : ns;
  return true;
}

bool parseNumbers(const std::string& line, char separator, std::vector<double>* out) {
  out->clear();
  std::vector<std::string> fields;
  if (separator == ' ') {
    std::string cur;
    for (char c : line) {
      if (std::isspace(static_cast<unsigned char>(c))) {
        if (!cur.empty()) fields.push_back(cur);
        cur.clear();
      } else {
        cur += c;
      }
    }
    if (!cur.empty()) fields.push_back(cur);
  } else {
    fields = split(line, separator);
  }
  for (const std::string& f : fields) {
    size_t start = f.find_first_not_of(' ');
    if (start == std::string::npos) return false;
    const char* b = f.data() + start;
    const char* e = f.data() + f.size();
    while (e > b && e[-1] == ' ') --e;
    double v = 0.0;
    auto [p, ec] = std::from_chars(b, e, v);
    if (ec != std::errc() || p != e) return false;
    out->push_back(v);
  }
  return true;
}

Expected<std::vector<imu::ImuSample>> readEurocImu(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  if (!in) return makeError(csv.string(), ": cannot open");
  std::vector<imu::ImuSample> out;
  std::string line;
  std::vector<double> v;
  for (int n = 1; std::getline(in, line); ++n) {
    if (isCommentOrBlank(line)) continue;
    imu::ImuSample s;
    int64_t t_ns = 0;
    if (!parseStamp(line, &t_ns) || !parseNumbers(line, ',', &v) || v.size() != 7) {
      return makeError(csv.string(), ":", n,
                       ": expected 7 numeric fields (t[ns], gyro xyz, accel xyz)");
    }
    s.utime = messages::utimeFromNs(t_ns);
    s.gyro_rad_s = Eigen::Vector3d(v[1], v[2], v[3]);
    s.accel_m_s2 = Eigen::Vector3d(v[4], v[5], v[6]);
    if (!s.gyro_rad_s.allFinite() || !s.accel_m_s2.allFinite()) {
      return makeError(csv.string(), ":", n, ": non-finite IMU value");
    }
    out.push_back(s);
  }
  return out;
}

Expected<std::vector<ImageEntry>> readEurocImages(const std::filesystem::path& csv) {
  std::vector<ImageEntry> out;
  const Status s = forEachDataLine(csv, [&](const std::string& line, int n) -> Status {
    const auto fields = split(line, ',');
    ImageEntry e;
    if (fields.size() != 2 || !parseStamp(fields[0], &e.t_ns)) {
      return makeError(csv.string(), ":", n, ": expected \"t[ns],filename\"");
    }
    e.filename = fields[1];
    const size_t a = e.filename.find_first_not_of(' ');
    e.filename = a == std::string::npos ? "" : e.filename.substr(a);
    if (e.filename.empty()) return makeError(csv.string(), ":", n, ": empty file name");
    out.push_back(e);
    return Ok{};
  });
  if (!s) return s.error();
  return out;
}

Expected<std::vector<StampedPose>> readEurocGroundTruth(const std::filesystem::path& file,
                                                        PoseFileLayout layout) {
  std::ifstream in(file);
  if (!in) return makeError(file.string(), ": cannot open");
  const bool tum = layout == PoseFileLayout::kTum ||
                   (layout == PoseFileLayout::kByExtension && file.extension() == ".txt");
  std::vector<StampedPose> out;
  std::string line;
  std::vector<double> v;
  for (int n = 1; std::getline(in, line); ++n) {
    if (isCommentOrBlank(line)) continue;
    StampedPose p;
    Eigen::Vector3d t;
    Eigen::Quaterniond q;
    if (tum) {
      if (!parseNumbers(line, ' ', &v) || v.size() != 8) {
        return makeError(file.string(), ":", n,
                         ": expected 8 numbers (TUM \"t x y z qx qy qz qw\")");
      }
      const size_t b = line.find_first_not_of(" \t");
      const std::string first = line.substr(b, line.find_first_of(" \t\r", b) - b);
      if (!parseSecondsToNs(first, &p.t_ns)) {
        return makeError(file.string(), ":", n, ": bad time stamp \"", first, "\"");
      }
      t = Eigen::Vector3d(v[1], v[2], v[3]);
      q = Eigen::Quaterniond(v[7], v[4], v[5], v[6]);
    } else {
      if (!parseStamp(line, &p.t_ns) || !parseNumbers(line, ',', &v) || v.size() < 8) {
        return makeError(file.string(), ":", n, ": expected \"t[ns], p xyz, q wxyz, ...\"");
      }
      t = Eigen::Vector3d(v[1], v[2], v[3]);
      q = Eigen::Quaterniond(v[4], v[5], v[6], v[7]);
    }
    if (!t.allFinite() || !q.coeffs().allFinite()) {
      return makeError(file.string(), ":", n, ": non-finite value in the pose");
    }
    // Files print quaternions with ~6 digits; a norm far from 1 means a wrong column order
    // or a corrupt line, not rounding.
    if (std::abs(q.norm() - 1.0) > 1e-2) {
      return makeError(file.string(), ":", n, ": quaternion norm ", q.norm(), " is not 1");
    }
    p.world_T_body = core::SE3d(q, t);
    out.push_back(p);
  }
  return out;
}

}  // namespace evermap::datasets
