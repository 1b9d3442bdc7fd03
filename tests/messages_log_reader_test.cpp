// LogReader: every event of an intact log, and one line for a log cut or damaged anywhere.

#include "tools/lcmlog/log_reader.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "scratch_dir.h"
#include "tools/lcmlog/log_writer.h"

namespace evermap::messages {
namespace {

using evermap::testing::ScratchDir;

std::string readAll(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}
void writeAll(const std::filesystem::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary) << bytes;
}

// Three events of 0, 5 and 300 bytes on two channels, written by LogWriter (lcm::LogFile).
std::filesystem::path writeLog(const ScratchDir& dir) {
  const auto file = dir / "three.lcmlog";
  auto w = LogWriter::open(file);
  EXPECT_TRUE(w.ok());
  EXPECT_TRUE(w->writeBytes("IMU", 10, {}).ok());
  EXPECT_TRUE(w->writeBytes("STEREO", 20, {1, 2, 3, 4, 5}).ok());
  EXPECT_TRUE(w->writeBytes("IMU", 30, std::vector<uint8_t>(300, 7)).ok());
  EXPECT_TRUE(w->commit().ok());
  return file;
}

TEST(LogReader, ReadsEveryEventOfAnIntactLogAsLcmDoes) {
  ScratchDir dir;
  const auto file = writeLog(dir);
  LogReader log(file);
  lcm::LogFile lcm_log(file.string(), "r");
  int n = 0;
  while (const LogReader::Event* e = log.next()) {
    const lcm::LogEvent* l = lcm_log.readNextEvent();
    ASSERT_NE(l, nullptr);
    EXPECT_EQ(e->eventnum, l->eventnum);
    EXPECT_EQ(e->timestamp, l->timestamp);
    EXPECT_EQ(e->channel, l->channel);
    ASSERT_EQ(e->datalen, l->datalen);
    EXPECT_EQ(std::vector<uint8_t>(e->data, e->data + e->datalen),
              std::vector<uint8_t>(static_cast<const uint8_t*>(l->data),
                                   static_cast<const uint8_t*>(l->data) + l->datalen));
    ++n;
  }
  EXPECT_EQ(lcm_log.readNextEvent(), nullptr);
  EXPECT_EQ(n, 3);
  EXPECT_EQ(log.events(), 3);
  EXPECT_TRUE(log.status().ok());
  EXPECT_EQ(log.next(), nullptr);
}

TEST(LogReader, AnEmptyFileIsALogWithoutEvents) {
  ScratchDir dir;
  const auto file = dir.write("empty.lcmlog", "");
  LogReader log(file);
  EXPECT_EQ(log.next(), nullptr);
  EXPECT_TRUE(log.status().ok());
}

TEST(LogReader, ALogCutAtAnyByteIsReportedTruncatedWithTheEventsReadBeforeIt) {
  ScratchDir dir;
  const std::string bytes = readAll(writeLog(dir));
  // Event boundaries: 28 + 3 + 0, then 28 + 6 + 5, then 28 + 3 + 300.
  const std::vector<size_t> ends = {31, 31 + 39, 31 + 39 + 331};
  ASSERT_EQ(bytes.size(), ends.back());
  const auto cut = dir / "cut.lcmlog";
  for (size_t size = 1; size < bytes.size(); ++size) {
    writeAll(cut, bytes.substr(0, size));
    LogReader log(cut);
    int64_t n = 0;
    while (log.next()) ++n;
    const bool at_boundary = std::find(ends.begin(), ends.end(), size) != ends.end();
    if (at_boundary) {
      EXPECT_TRUE(log.status().ok()) << size;
      continue;
    }
    const Status s = log.status();
    ASSERT_FALSE(s.ok()) << "cut at " << size << " bytes not seen";
    const std::string& m = s.error().message;
    EXPECT_NE(m.find("truncated at byte"), std::string::npos) << m;
    EXPECT_NE(m.find(cut.string()), std::string::npos) << m;
    EXPECT_NE(m.find("after " + std::to_string(n) + " complete events"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << "one line: " << m;
    EXPECT_EQ(log.events(), n);
  }
}

TEST(LogReader, ABadSyncWordIsCorruptNotSkipped) {
  ScratchDir dir;
  std::string bytes = readAll(writeLog(dir));
  bytes[31] = 'X';  // the second event's sync word
  const auto file = dir / "bad.lcmlog";
  writeAll(file, bytes);
  LogReader log(file);
  EXPECT_NE(log.next(), nullptr);
  EXPECT_EQ(log.next(), nullptr);
  ASSERT_FALSE(log.status().ok());
  EXPECT_NE(log.status().error().message.find("corrupt at byte 31 (event 2"), std::string::npos)
      << log.status().error().message;
}

TEST(LogReader, LengthsBeyondLcmsLimitsAreRefusedBeforeAnyAllocation) {
  ScratchDir dir;
  const std::string good = readAll(writeLog(dir));
  const auto file = dir / "bad.lcmlog";
  // Channel length (bytes 20..23) of 2^31 - 1, 0 and 1000; data length (24..27) of -1 and
  // 2^31 - 1: lcm::LogFile asserts or allocates gigabytes for these.
  const std::vector<std::pair<int, std::string>> cases = {
      {20, std::string("\x7f\xff\xff\xff", 4)}, {20, std::string("\0\0\0\0", 4)},
      {20, std::string("\0\0\x03\xe8", 4)},     {24, std::string("\xff\xff\xff\xff", 4)},
      {24, std::string("\x7f\xff\xff\xff", 4)}, {24, std::string("\x0f\xff\xff\xff", 4)}};
  for (const auto& [at, value] : cases) {
    std::string bytes = good;
    bytes.replace(static_cast<size_t>(at), 4, value);
    writeAll(file, bytes);
    LogReader log(file);
    EXPECT_EQ(log.next(), nullptr);
    ASSERT_FALSE(log.status().ok()) << at;
    EXPECT_NE(log.status().error().message.find("at byte 0 (event 1, after 0 complete events)"),
              std::string::npos)
        << log.status().error().message;
  }
}

TEST(LogReader, AMissingFileOrAFolderIsAnErrorNamingIt) {
  ScratchDir dir;
  auto missing = LogReader::open(dir / "nope.lcmlog");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("nope.lcmlog: no such log file"), std::string::npos);
  auto folder = LogReader::open(dir.path());
  ASSERT_FALSE(folder.ok());
  EXPECT_NE(folder.error().message.find("is a folder"), std::string::npos);
  LogReader constructed(dir / "nope.lcmlog");
  EXPECT_EQ(constructed.next(), nullptr);
  EXPECT_FALSE(constructed.status().ok());
}

TEST(LogReader, CheckCountsTheEventsAndFindsWhatNextWouldFind) {
  ScratchDir dir;
  const auto file = writeLog(dir);
  auto n = LogReader::check(file);
  ASSERT_TRUE(n.ok()) << n.error().message;
  EXPECT_EQ(*n, 3);
  const std::string bytes = readAll(file);
  const auto cut = dir / "cut.lcmlog";
  for (size_t size : {size_t{1}, size_t{45}, bytes.size() - 1}) {
    writeAll(cut, bytes.substr(0, size));
    LogReader log(cut);
    while (log.next()) {
    }
    auto checked = LogReader::check(cut);
    ASSERT_FALSE(checked.ok()) << size;
    EXPECT_EQ(checked.error().message, log.status().error().message);
  }
}

}  // namespace
}  // namespace evermap::messages
