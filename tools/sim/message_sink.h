#pragma once
// Where simulated messages go: an LCM log, LCM itself, a counter, a test's vector. Messages
// arrive encoded (the bytes LCM would carry) and in time order.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace evermap::sim {

class MessageSink {
 public:
  virtual ~MessageSink() = default;
  virtual void write(const std::string& channel, int64_t utime,
                     const std::vector<uint8_t>& data) = 0;
};

// Encodes an LCM message and hands it to the sink.
template <typename Message>
void writeMessage(MessageSink& sink, const std::string& channel, const Message& message) {
  std::vector<uint8_t> data(static_cast<size_t>(message.getEncodedSize()));
  message.encode(data.data(), 0, static_cast<int>(data.size()));
  sink.write(channel, message.utime, data);
}

struct ChannelCount {
  int64_t messages = 0;
  int64_t bytes = 0;
};

// Counts messages and bytes per channel, then forwards to `next` (if any).
class CountingSink final : public MessageSink {
 public:
  explicit CountingSink(MessageSink* next = nullptr) : next_(next) {}
  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override {
    ChannelCount& c = counts_[channel];
    ++c.messages;
    c.bytes += static_cast<int64_t>(data.size());
    if (next_) next_->write(channel, utime, data);
  }
  const std::map<std::string, ChannelCount>& counts() const { return counts_; }

 private:
  MessageSink* next_;
  std::map<std::string, ChannelCount> counts_;
};

// Drops every message.
class NullSink final : public MessageSink {
 public:
  void write(const std::string&, int64_t, const std::vector<uint8_t>&) override {}
};

// Keeps every message (tests).
class VectorSink final : public MessageSink {
 public:
  struct Message {
    std::string channel;
    int64_t utime;
    std::vector<uint8_t> data;
  };
  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override {
    messages.push_back(Message{channel, utime, data});
  }
  std::vector<Message> messages;
};

}  // namespace evermap::sim
