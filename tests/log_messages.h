#pragma once
// The messages of one channel of an LCM log, decoded, for tests that check what a program
// wrote.

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/messages/convert.h"

namespace evermap::testing {

// Appends the messages on `channel` of the log `file` to *out, in order; a message that does
// not decode fails the test (call inside ASSERT_NO_FATAL_FAILURE).
template <typename Msg>
void readLogMessages(const std::filesystem::path& file, const std::string& channel,
                     std::vector<Msg>* out) {
  lcm::LogFile log(file.string(), "r");
  ASSERT_TRUE(log.good()) << file;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    if (e->channel != channel) continue;
    auto m = messages::decodeLcm<Msg>(e->data, e->datalen, e->channel);
    ASSERT_TRUE(m.ok()) << m.error().message;
    out->push_back(std::move(*m));
  }
}

}  // namespace evermap::testing
