#include "core/messages/envelope.h"

#include <sodium.h>
#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace evermap::messages {
namespace {

constexpr uint8_t kMagic[8] = {'e', 'v', 'm', 'e', 'n', 'v', '0', '1'};
constexpr uint8_t kFlagMac = 1;
constexpr int kMacBytes = 32;
constexpr int kFixedBytes = 24;  // instance, counter, wall
static_assert(MacKey::kBytes >= crypto_generichash_KEYBYTES_MIN &&
              MacKey::kBytes <= crypto_generichash_KEYBYTES_MAX);
static_assert(kMacBytes >= crypto_generichash_BYTES_MIN &&
              kMacBytes <= crypto_generichash_BYTES_MAX);

// libsodium must be initialised once before use; sodium_init() may be called again (and from
// several threads) at no harm.
void initSodium() {
  if (sodium_init() < 0) {
    std::fprintf(stderr, "evermap: libsodium cannot be initialised\n");
    std::abort();
  }
}

void putU64(std::vector<uint8_t>& b, uint64_t v) {
  for (int k = 7; k >= 0; --k) b.push_back(static_cast<uint8_t>(v >> (8 * k)));
}

uint64_t getU64(const uint8_t* p) {
  uint64_t v = 0;
  for (int k = 0; k < 8; ++k) v = (v << 8) | p[k];
  return v;
}

// The mac: keyed BLAKE2b-256 (libsodium's crypto_generichash with a key, which its
// documentation gives as a MAC; twice as fast as HMAC-SHA-512-256 here, results/reliability.md),
// over the channel name (its length first, so that no channel/message split is
// ambiguous), then `a` and `b` (the message with the trailer's head, and the footer).
void computeMac(const MacKey& key, const std::string& channel, const uint8_t* a, size_t a_size,
                const uint8_t* b, size_t b_size, uint8_t* mac) {
  initSodium();
  crypto_generichash_state state;
  crypto_generichash_init(&state, key.data(), MacKey::kBytes, kMacBytes);
  const uint8_t length[2] = {static_cast<uint8_t>(channel.size() >> 8),
                             static_cast<uint8_t>(channel.size())};
  crypto_generichash_update(&state, length, sizeof length);
  crypto_generichash_update(&state, reinterpret_cast<const uint8_t*>(channel.data()),
                            channel.size());
  crypto_generichash_update(&state, a, a_size);
  crypto_generichash_update(&state, b, b_size);
  crypto_generichash_final(&state, mac, kMacBytes);
  sodium_memzero(&state, sizeof state);
}

int64_t wallUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

std::string SenderId::toString() const {
  if (anonymous()) return "anonymous";
  std::string s;
  for (char c : process) s += (c >= 0x20 && c < 0x7f) ? c : '?';
  char hex[20];
  std::snprintf(hex, sizeof hex, "#%016llx", static_cast<unsigned long long>(instance));
  return s + hex;
}

Expected<MacKey> MacKey::load(const std::filesystem::path& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0)
    return makeError("--key ", file.string(), ": cannot read it (", std::strerror(errno), ")");
  if (!S_ISREG(st.st_mode)) return makeError("--key ", file.string(), ": not a regular file");
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%03o", static_cast<unsigned>(st.st_mode & 0777));
    return makeError("--key ", file.string(), ": mode ", mode,
                     " lets group or others at it; make it readable by its owner only "
                     "(chmod 600)");
  }
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) return makeError("--key ", file.string(), ": cannot read it");
  std::string hex;
  for (char c : text.str()) {
    if (!std::isspace(static_cast<unsigned char>(c))) hex += c;
  }
  std::array<uint8_t, kBytes> bytes{};
  size_t used = 0;
  initSodium();
  if (hex.size() != 2 * kBytes ||
      sodium_hex2bin(bytes.data(), bytes.size(), hex.data(), hex.size(), nullptr, &used, nullptr) !=
          0 ||
      used != kBytes) {
    return makeError("--key ", file.string(), ": must hold ", 2 * kBytes,
                     " hex digits (e.g. from `openssl rand -hex 32`)");
  }
  MacKey key = fromBytes(bytes);
  sodium_memzero(bytes.data(), bytes.size());
  return key;
}

MacKey MacKey::fromBytes(const std::array<uint8_t, kBytes>& bytes) {
  MacKey k;
  k.bytes_ = bytes;
  return k;
}

void appendEnvelope(const std::string& channel, const Envelope& envelope, const MacKey* key,
                    std::vector<uint8_t>& bytes) {
  const std::string& name = envelope.sender.process;
  const size_t n = std::min<size_t>(name.size(), kMaxSenderName);
  bytes.insert(bytes.end(), name.begin(), name.begin() + static_cast<std::ptrdiff_t>(n));
  putU64(bytes, envelope.sender.instance);
  putU64(bytes, envelope.counter);
  putU64(bytes, static_cast<uint64_t>(envelope.wall_utime));
  uint8_t footer[kEnvelopeFooterBytes] = {static_cast<uint8_t>(n),
                                          static_cast<uint8_t>(key ? kFlagMac : 0)};
  std::memcpy(footer + 2, kMagic, sizeof kMagic);
  if (key) {
    uint8_t mac[kMacBytes];
    computeMac(*key, channel, bytes.data(), bytes.size(), footer, sizeof footer, mac);
    bytes.insert(bytes.end(), mac, mac + kMacBytes);
  }
  bytes.insert(bytes.end(), footer, footer + sizeof footer);
}

Expected<Opened> openEnvelope(const std::string& channel, const void* data, int64_t size,
                              const MacKey* key) {
  const auto* p = static_cast<const uint8_t*>(data);
  Opened out;
  out.message_size = size;
  if (size < kEnvelopeFooterBytes ||
      std::memcmp(p + size - sizeof kMagic, kMagic, sizeof kMagic) != 0)
    return out;
  const uint8_t* footer = p + size - kEnvelopeFooterBytes;
  const int n = footer[0];
  const uint8_t flags = footer[1];
  if (n > kMaxSenderName) return makeError("envelope: sender name of ", n, " bytes (at most 64)");
  if ((flags & ~kFlagMac) != 0) return makeError("envelope: unknown flags ", int{flags});
  const int mac_bytes = (flags & kFlagMac) ? kMacBytes : 0;
  const int64_t trailer = n + kFixedBytes + mac_bytes + kEnvelopeFooterBytes;
  if (trailer > size)
    return makeError("envelope: ", trailer, " bytes of trailer, ", size, " in the message");
  const uint8_t* t = p + size - trailer;
  Envelope e;
  e.sender.process.assign(reinterpret_cast<const char*>(t), static_cast<size_t>(n));
  e.sender.instance = getU64(t + n);
  e.counter = getU64(t + n + 8);
  e.wall_utime = static_cast<int64_t>(getU64(t + n + 16));
  e.has_mac = mac_bytes > 0;
  if (e.sender.anonymous()) return makeError("envelope: no sender name and instance 0");
  if (key && e.has_mac) {
    uint8_t mac[kMacBytes];
    const int64_t head = size - kEnvelopeFooterBytes - mac_bytes;  // message + name + fixed
    computeMac(*key, channel, p, static_cast<size_t>(head), footer, kEnvelopeFooterBytes, mac);
    out.mac_valid = crypto_verify_32(mac, p + head) == 0;
  }
  out.message_size = size - trailer;
  out.envelope = std::move(e);
  return out;
}

int64_t messageSize(const void* data, int64_t size) {
  auto opened = openEnvelope("", data, size, nullptr);
  return opened ? opened->message_size : size;
}

Signer Signer::make(std::string process, std::shared_ptr<const MacKey> key) {
  initSodium();
  Signer s;
  s.state_ = std::make_shared<State>();
  if (process.size() > static_cast<size_t>(kMaxSenderName)) process.resize(kMaxSenderName);
  s.state_->sender.process = std::move(process);
  uint64_t instance = 0;
  while (instance == 0) randombytes_buf(&instance, sizeof instance);
  s.state_->sender.instance = instance;
  s.state_->key = std::move(key);
  return s;
}

SenderId Signer::sender() const { return state_ ? state_->sender : SenderId{}; }

void Signer::seal(const std::string& channel, std::vector<uint8_t>& bytes) const {
  if (!state_) return;
  Envelope e;
  e.sender = state_->sender;
  e.counter = ++state_->counter;
  e.wall_utime = wallUtime();
  appendEnvelope(channel, e, state_->key.get(), bytes);
}

}  // namespace evermap::messages
