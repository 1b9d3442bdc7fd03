#pragma once
// The envelope: who sent an LCM message, and (with a shared key) proof that it was someone who
// holds the key (issue 47). Every evermap process appends a trailer to the encoded message it
// publishes; the receiving Inbox strips and checks it before the message is decoded. LCM,
// lcm-logger and lcm-spy see a longer message and ignore the bytes behind it (every LCM decoder
// stops at the end of its type's fields).
//
// The trailer, after the encoded message (integers big-endian, as LCM's):
//
//   name[n]   the sender's process name ("evermap-vo-proc"), n in [0, 64] bytes
//   instance  u64, random, drawn when the process starts (a restarted process is a new sender)
//   counter   u64, the sender's messages so far (any channel), from 1
//   wall      i64, the sender's wall-clock time when it sent, µs since 1970
//   mac[32]   with a key only: keyed BLAKE2b-256 (libsodium crypto_generichash) over the channel
//   name,
//             the message and the trailer without the mac
//   n         u8
//   flags     u8, bit 0: a mac is present (other bits 0)
//   magic[8]  "evmenv01"
//
// A message without the magic at its end has no envelope: an anonymous sender (lcm-logplayer
// replaying a converted log, a log recorded before envelopes, a foreign tool). Eight bytes make
// a message that ends in the magic by chance a 2^-64 event.

#include <array>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/common/expected.h"

namespace evermap::messages {

// A sender: a process name and the random instance drawn when it started. The anonymous
// sender (messages without an envelope) has an empty name and instance 0.
struct SenderId {
  std::string process;
  uint64_t instance = 0;

  bool anonymous() const { return process.empty() && instance == 0; }
  bool operator==(const SenderId&) const = default;
  // "evermap-vo-proc#3fa2c1d09b7e4410", "anonymous"; bytes outside printable ASCII as '?'.
  std::string toString() const;
};

// A 32-byte shared key (crypto_auth_KEYBYTES).
class MacKey {
 public:
  static constexpr int kBytes = 32;
  // The file holds the key as 64 hex digits (whitespace around them ignored), e.g. from
  // `(umask 077; openssl rand -hex 32 > evermap.key)`. Refused (an Error naming the file) when
  // group or others may read or write it, when it is not a regular file, or when the text is
  // not 64 hex digits.
  static Expected<MacKey> load(const std::filesystem::path& file);
  static MacKey fromBytes(const std::array<uint8_t, kBytes>& bytes);
  const uint8_t* data() const { return bytes_.data(); }

 private:
  std::array<uint8_t, kBytes> bytes_{};
};

// What an envelope says.
struct Envelope {
  SenderId sender;
  uint64_t counter = 0;
  int64_t wall_utime = 0;
  bool has_mac = false;
};

// A received message split into the LCM message and its envelope.
struct Opened {
  int64_t message_size = 0;          // the encoded LCM message's bytes (the buffer's start)
  std::optional<Envelope> envelope;  // none: an anonymous sender
  bool mac_valid = false;            // with a key: the mac is there and right
};

constexpr int kMaxSenderName = 64;
constexpr int kEnvelopeFooterBytes = 10;  // n, flags, magic

// Splits `data` (one LCM event as received) into message and envelope; with `key`, checks the
// mac. An Error when the magic is there but the trailer does not fit the bytes (a damaged or
// forged envelope).
Expected<Opened> openEnvelope(const std::string& channel, const void* data, int64_t size,
                              const MacKey* key);

// The bytes of the LCM message in an event (the whole event when it has no envelope, or a
// damaged one): for readers of logs, which decode what was recorded.
int64_t messageSize(const void* data, int64_t size);

// The sending side of one process: its identity, its key (none: no mac) and its counter,
// shared by every copy (an Inbox's, an Outbox's) and thread-safe. A default Signer appends
// nothing: its messages are anonymous, as before envelopes (tests, tools that forge).
class Signer {
 public:
  Signer() = default;
  // A named sender with a fresh random instance (libsodium's randombytes). `process` is cut
  // to kMaxSenderName bytes.
  static Signer make(std::string process, std::shared_ptr<const MacKey> key);

  bool anonymous() const { return !state_; }
  SenderId sender() const;
  const MacKey* key() const { return state_ ? state_->key.get() : nullptr; }
  // Appends the trailer to `bytes` (an encoded LCM message for `channel`); nothing when
  // anonymous. The counter and the wall clock are read here.
  void seal(const std::string& channel, std::vector<uint8_t>& bytes) const;

 private:
  struct State {
    SenderId sender;
    std::shared_ptr<const MacKey> key;
    std::atomic<uint64_t> counter{0};
  };
  std::shared_ptr<State> state_;
};

// The trailer for `envelope` (the counter and wall clock as given; for tests and the bench).
void appendEnvelope(const std::string& channel, const Envelope& envelope, const MacKey* key,
                    std::vector<uint8_t>& bytes);

}  // namespace evermap::messages
