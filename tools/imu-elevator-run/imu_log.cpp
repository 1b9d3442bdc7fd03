#include "core/messages/convert.h"
#include "tools/imu-elevator-run/imu_log.h"

#include <cstdio>
#include <filesystem>
#include <vector>

#include <evermap/imu_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "core/imu/lcm_convert.h"
#include "tools/lcmlog/log_reader.h"

namespace evermap::imu {

Expected<ImuLog> readImuLog(const std::string& file, const std::string& channel) {
  auto opened = messages::LogReader::open(file);
  if (!opened) return opened.error();
  messages::LogReader& log = *opened;
  ImuLog out;
  while (const messages::LogReader::Event* ev = log.next()) {
    if (ev->channel != channel) continue;
    auto m = messages::decodeLcm<imu_t>(ev->data, ev->datalen, channel);
    if (!m) {
      ++out.undecodable;
      continue;
    }
    out.samples.push_back(fromLcm(*m));
  }
  if (Status s = log.status(); !s) return s.error();  // cut mid-event or damaged
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
      if (log.writeEvent(&ev) != 0) {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
        return makeError(tmp, ": write failed");
      }
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) return makeError(file, ": cannot rename from ", tmp, ": ", ec.message());
  return Ok{};
}

}  // namespace evermap::imu
