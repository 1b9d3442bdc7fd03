// evermap-loopclose-proc: the loop-closure service (DESIGN.md section 1). Parses options, loads
// the vocabulary, opens the map store, wires LCM and runs the loop; the logic is LoopCloser.
// Exit status: 0 on SIGINT/SIGTERM, 1 bad input (vocabulary, store), 2 bad command line.

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <optional>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "core/bow/vocabulary_io.h"
#include "loopclose-proc/core_registration.h"
#include "loopclose-proc/loop_closer.h"
#include "loopclose-proc/server.h"

namespace {

using namespace evermap;
using namespace evermap::loopclose;

constexpr const char* kUsage =
    "usage: evermap-loopclose-proc --vocab FILE [--store MAP.db] [--lcm-url URL] [--rate HZ]\n"
    "  --vocab FILE     vocabulary: evermap .evoc (evermap-vocab-train) or DBoW2/DBoW3 .yml.gz\n"
    "  --store MAP.db   SQLite map store: nodes and keyframes are reloaded and persisted\n"
    "  --lcm-url URL    LCM provider (default: LCM's default, $LCM_DEFAULT_URL)\n"
    "  --rate HZ        answers per second of data time (default 2)\n";

// The frame registration: the pluggable part (registration.h); core/registration's by default.
std::unique_ptr<FrameRegistration> makeRegistration() {
  auto r = CoreRegistration::create(core::RegistrationOptions{});
  if (!r) return nullptr;
  return std::make_unique<CoreRegistration>(std::move(*r));
}

}  // namespace

int main(int argc, char** argv) {
  std::string vocab_file, store_file, url;
  LoopCloserOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "evermap-loopclose-proc: %s needs a value\n%s", a.c_str(), kUsage);
      return 2;
    }
    const std::string v = argv[++i];
    if (a == "--vocab") {
      vocab_file = v;
    } else if (a == "--store") {
      store_file = v;
    } else if (a == "--lcm-url") {
      url = v;
    } else if (a == "--rate") {
      char* end = nullptr;
      options.max_rate_hz = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end) {
        std::fprintf(stderr, "evermap-loopclose-proc: bad --rate %s\n", v.c_str());
        return 2;
      }
    } else {
      std::fprintf(stderr, "evermap-loopclose-proc: unknown option %s\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  if (vocab_file.empty()) {
    std::fprintf(stderr, "evermap-loopclose-proc: --vocab is required\n%s", kUsage);
    return 2;
  }
  auto vocabulary = bow::loadAnyVocabulary(vocab_file);
  if (!vocabulary) {
    std::fprintf(stderr, "evermap-loopclose-proc: %s\n", vocabulary.error().message.c_str());
    return 1;
  }
  std::optional<bow::PlaceStore> store;
  if (!store_file.empty()) {
    auto s = bow::PlaceStore::open(store_file, vocabulary->fingerprint(), vocabulary->numWords());
    if (!s) {
      std::fprintf(stderr, "evermap-loopclose-proc: %s\n", s.error().message.c_str());
      return 1;
    }
    store = std::move(*s);
  }
  const std::unique_ptr<FrameRegistration> registration = makeRegistration();
  if (!registration) {
    std::fprintf(stderr, "evermap-loopclose-proc: invalid default registration options\n");
    return 1;
  }
  auto loop_closer = LoopCloser::create(*vocabulary, *registration, options, std::move(store));
  if (!loop_closer) {
    std::fprintf(stderr, "evermap-loopclose-proc: %s\n", loop_closer.error().message.c_str());
    return 1;
  }
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-loopclose-proc: cannot start LCM (%s)\n",
                 url.empty() ? "default URL" : url.c_str());
    return 1;
  }
  LoopCloseServer server(lcm, **loop_closer);
  std::printf("loopclose-proc: vocabulary %s (%zu words), %zu nodes loaded, registration: %s\n",
              vocab_file.c_str(), vocabulary->numWords(), (*loop_closer)->numNodes(),
              registration->describe().c_str());
  std::fflush(stdout);

  // SIGINT/SIGTERM are blocked and polled between LCM waits: no handler, no global flag.
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGINT);
  sigaddset(&stop, SIGTERM);
  sigprocmask(SIG_BLOCK, &stop, nullptr);
  const timespec no_wait{0, 0};
  while (sigtimedwait(&stop, nullptr, &no_wait) < 0) {
    if (lcm.handleTimeout(200) < 0) {
      std::fprintf(stderr, "evermap-loopclose-proc: LCM failed\n");
      break;
    }
  }
  std::printf("loopclose-proc: %s; %lld messages dropped, %lld results published\n",
              (*loop_closer)->stats().text().c_str(), static_cast<long long>(server.dropped()),
              static_cast<long long>(server.published()));
  return 0;
}
