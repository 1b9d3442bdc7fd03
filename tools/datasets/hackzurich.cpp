#include "tools/datasets/hackzurich.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/messages/convert.h"

namespace evermap::datasets {

namespace {

constexpr double kStandardGravity = 9.80665;

// "unix_time_s,date_iso,v1,v2,..." -> t_ns and the numbers after the date.
bool parseRow(const std::string& line, int64_t* t_ns, std::vector<double>* values) {
  values->clear();
  std::stringstream ss(line);
  std::string field;
  int i = 0;
  while (std::getline(ss, field, ',')) {
    if (i == 1) {  // the ISO date repeats the time stamp
      ++i;
      continue;
    }
    char* end = nullptr;
    const double v = std::strtod(field.c_str(), &end);
    if (end == field.c_str()) return false;
    if (i == 0) {
      // Seconds with millisecond digits: round to whole microseconds to avoid 1e-7 noise.
      *t_ns = static_cast<int64_t>(std::llround(v * 1e6)) * 1000;
    } else {
      values->push_back(v);
    }
    ++i;
  }
  return i >= 3;
}

template <typename OnRow>
Status readCsv(const std::filesystem::path& file, size_t min_values, OnRow on_row) {
  std::ifstream in(file);
  if (!in) return makeError(file.string(), ": cannot open");
  std::string line;
  std::vector<double> values;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n == 1 || line.empty()) continue;  // header
    int64_t t_ns = 0;
    if (!parseRow(line, &t_ns, &values) || values.size() < min_values) {
      return makeError(file.string(), ":", n, ": expected \"unix_time_s,date_iso,", min_values,
                       " numbers\"");
    }
    on_row(t_ns, values);
  }
  return Ok{};
}

// The text after "key": up to the next ',' or '}' (numbers) or the closing quote (strings).
bool jsonValue(const std::string& object, const std::string& key, std::string* out) {
  const auto k = object.find("\"" + key + "\"");
  if (k == std::string::npos) return false;
  auto p = object.find(':', k);
  if (p == std::string::npos) return false;
  p = object.find_first_not_of(" \t\r\n", p + 1);
  if (p == std::string::npos) return false;
  if (object[p] == '"') {
    std::string s;
    for (size_t i = p + 1; i < object.size(); ++i) {
      if (object[i] == '\\' && i + 1 < object.size()) {
        s += object[++i];
      } else if (object[i] == '"') {
        *out = s;
        return true;
      } else {
        s += object[i];
      }
    }
    return false;
  }
  const auto e = object.find_first_of(",}\n", p);
  *out = object.substr(p, e == std::string::npos ? std::string::npos : e - p);
  return true;
}

}  // namespace

Expected<std::vector<LabelledEpisode>> readHackzurichEpisodes(const std::filesystem::path& json) {
  std::ifstream in(json);
  if (!in) return makeError(json.string(), ": cannot open");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  std::vector<LabelledEpisode> out;
  size_t pos = 0;
  while ((pos = text.find('{', pos)) != std::string::npos) {
    const auto end = text.find('}', pos);
    if (end == std::string::npos) return makeError(json.string(), ": unterminated object");
    const std::string object = text.substr(pos, end - pos + 1);
    pos = end + 1;
    std::string start, stop;
    LabelledEpisode e;
    if (!jsonValue(object, "start_time", &start) || !jsonValue(object, "end_time", &stop)) {
      return makeError(json.string(), ": episode without start_time/end_time");
    }
    try {
      e.start_ns = static_cast<int64_t>(std::llround(std::stod(start) * 1e6)) * 1000;
      e.end_ns = static_cast<int64_t>(std::llround(std::stod(stop) * 1e6)) * 1000;
    } catch (...) {
      return makeError(json.string(), ": bad time \"", start, "\" or \"", stop, "\"");
    }
    jsonValue(object, "label", &e.label);
    jsonValue(object, "description", &e.description);
    out.push_back(e);
  }
  return out;
}

Expected<HackzurichSession> readHackzurichSession(const std::filesystem::path& dir, int session,
                                                  double max_gyro_offset_s) {
  const std::string prefix = "session" + std::to_string(session) + "_";
  HackzurichSession s;
  struct Row {
    int64_t t_ns;
    Eigen::Vector3d v;
  };
  std::vector<Row> accel, gyro;
  auto collect = [](std::vector<Row>* rows) {
    return [rows](int64_t t, const std::vector<double>& v) {
      rows->push_back({t, Eigen::Vector3d(v[0], v[1], v[2])});
    };
  };
  if (Status st = readCsv(dir / (prefix + "accelerometer.csv"), 3, collect(&accel)); !st.ok()) {
    return st.error();
  }
  // Without a gyrometer file the session is accelerometer-only: every accelerometer row is
  // kept, with a zero gyro (which the attitude filter's auto mode takes as "no gyroscope").
  s.has_gyroscope = std::filesystem::exists(dir / (prefix + "gyrometer.csv"));
  if (s.has_gyroscope) {
    if (Status st = readCsv(dir / (prefix + "gyrometer.csv"), 3, collect(&gyro)); !st.ok()) {
      return st.error();
    }
  }
  Status st =
      readCsv(dir / (prefix + "barometer.csv"), 2, [&s](int64_t t, const std::vector<double>& v) {
        s.barometer.push_back({t, v[0], v[1]});
      });
  if (!st.ok()) return st.error();
  // Gyro rows in time order for the search (the files are, but do not rely on it).
  std::stable_sort(gyro.begin(), gyro.end(),
                   [](const Row& a, const Row& b) { return a.t_ns < b.t_ns; });
  const int64_t max_offset_ns = static_cast<int64_t>(max_gyro_offset_s * 1e9);
  s.accelerometer_rows = static_cast<int64_t>(accel.size());
  for (const Row& a : accel) {  // kept in file order: time-order problems are the gate's
    auto it = std::lower_bound(gyro.begin(), gyro.end(), a.t_ns,
                               [](const Row& r, int64_t t) { return r.t_ns < t; });
    const Row* after = it != gyro.end() && it->t_ns - a.t_ns <= max_offset_ns ? &*it : nullptr;
    const Row* before =
        it != gyro.begin() && a.t_ns - (it - 1)->t_ns <= max_offset_ns ? &*(it - 1) : nullptr;
    Eigen::Vector3d w;
    if (before && after && after->t_ns > before->t_ns) {
      const double f = static_cast<double>(a.t_ns - before->t_ns) /
                       static_cast<double>(after->t_ns - before->t_ns);
      w = (1 - f) * before->v + f * after->v;
    } else if (before || after) {
      w = (before ? before : after)->v;
    } else if (!s.has_gyroscope) {
      w.setZero();
    } else {
      ++s.rows_without_gyro;
      continue;
    }
    imu::ImuSample x;
    x.utime = messages::utimeFromNs(a.t_ns);
    x.gyro_rad_s = w;
    x.accel_m_s2 = -kStandardGravity * a.v;  // iOS: g units, negative specific force
    s.imu.push_back(x);
  }
  // Episode labels: every sessionN*episode*.json in the folder.
  std::vector<std::filesystem::path> labels;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) == 0 && name.find("episode") != std::string::npos &&
        entry.path().extension() == ".json") {
      labels.push_back(entry.path());
    }
  }
  std::sort(labels.begin(), labels.end());
  for (const auto& file : labels) {
    auto episodes = readHackzurichEpisodes(file);
    if (!episodes.ok()) return episodes.error();
    s.episodes.insert(s.episodes.end(), episodes->begin(), episodes->end());
  }
  return s;
}

}  // namespace evermap::datasets
