#include "core/messages/outbox.h"

namespace evermap::messages {

int Outbox::publishBytes(const std::string& channel, const void* data, int64_t size) const {
  const int64_t message = messageSize(data, size);
  const auto* p = static_cast<const uint8_t*>(data);
  return send(channel, std::vector<uint8_t>(p, p + message));
}

int Outbox::send(const std::string& channel, std::vector<uint8_t> bytes) const {
  signer_.seal(channel, bytes);
  return lcm_.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size()));
}

}  // namespace evermap::messages
