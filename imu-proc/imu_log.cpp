#include "core/messages/convert.h"
#include "imu-proc/imu_log.h"

#include <cstdio>
#include <filesystem>
#include <vector>

#include <evermap/imu_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "imu-proc/lcm_convert.h"

namespace evermap::imu {

Expected<ImuLog> readImuLog(const std::string& file, const std::string& channel) {
  if (!std::filesystem::exists(file)) return makeError(file, ": no such file");
  lcm::LogFile log(file, "r");
  if (!log.good()) return makeError(file, ": cannot open as an LCM log");
  ImuLog out;
  for (const lcm::LogEvent* ev = log.readNextEvent(); ev; ev = log.readNextEvent()) {
    if (ev->channel != channel) continue;
    auto m = messages::decodeLcm<imu_t>(ev->data, ev->datalen, channel);
    if (!m) {
      ++out.undecodable;
      continue;
    }
    out.samples.push_back(fromLcm(*m));
  }
  return out;
}

Status writeImuLog(const std::string& file, const std::string& channel,
                   const std::vector<ImuSample>& samples) {
  const std::string tmp = file + ".tmp";
  {
    lcm::LogFile log(tmp, "w");
    if (!log.good()) return makeError(tmp, ": cannot write");
    std::vector<uint8_t> buf;
    int64_t n = 0;
    for (const ImuSample& s : samples) {
      const imu_t m = toLcm(s);
      buf.resize(m.getEncodedSize());
      m.encode(buf.data(), 0, static_cast<int>(buf.size()));
      lcm::LogEvent ev;
      ev.eventnum = n++;
      ev.timestamp = s.utime;
      ev.channel = channel;
      ev.datalen = static_cast<int32_t>(buf.size());
      ev.data = buf.data();
      if (log.writeEvent(&ev) != 0) return makeError(tmp, ": write failed");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) return makeError(file, ": cannot rename from ", tmp, ": ", ec.message());
  return Ok{};
}

}  // namespace evermap::imu
