// evermap-loopclose-proc: the loop-closure service (DESIGN.md section 1). Parses options, loads
// the vocabulary, opens the map store, wires LCM and runs the loop; the logic is LoopCloser.
// Exit status: 0 on SIGINT/SIGTERM, 1 bad input (vocabulary, store), 2 bad command line.

#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "core/bow/vocabulary_io.h"
#include "core/common/command_line.h"
#include "core/common/stop_signals.h"
#include "core/messages/key_option.h"
#include "loopclose-proc/core_registration.h"
#include "loopclose-proc/loop_closer.h"
#include "loopclose-proc/server.h"

namespace {

using namespace evermap;
using namespace evermap::loopclose;

// The frame registration: the pluggable part (registration.h); core/registration's by default.
std::unique_ptr<FrameRegistration> makeRegistration() {
  auto r = CoreRegistration::create(core::RegistrationOptions{});
  if (!r) return nullptr;
  return std::make_unique<CoreRegistration>(std::move(*r));
}

// The place store of --store (none without it), read-only with --read-only.
Expected<std::optional<bow::PlaceStore>> openStore(const std::string& file, bool read_only,
                                                   const bow::Vocabulary& vocabulary) {
  if (file.empty()) return std::optional<bow::PlaceStore>();
  auto s = read_only ? bow::PlaceStore::openReadOnly(file, vocabulary.fingerprint(),
                                                     vocabulary.numWords())
                     : bow::PlaceStore::open(file, vocabulary.fingerprint(), vocabulary.numWords());
  if (!s) return s.error();
  return std::optional<bow::PlaceStore>(std::move(*s));
}

}  // namespace

int main(int argc, char** argv) {
  std::string vocab_file, store_file, url, key_file;
  bool read_only = false;
  LoopCloserOptions options;
  CommandLine cli("evermap-loopclose-proc",
                  "The loop-closure service: place recognition and frame registration on LCM.");
  cli.value("--vocab", &vocab_file, "FILE",
            "vocabulary: evermap .evoc (evermap-vocab-train) or DBoW2/DBoW3 .yml.gz", true);
  cli.value("--store", &store_file, "MAP.db",
            "SQLite map store: nodes and keyframes are reloaded and persisted");
  cli.flag("--read-only", &read_only,
           "open --store read-only (localization, docs/localization.md): its places are "
           "searched, nothing is written, the file's bytes do not change");
  cli.value("--lcm-url", &url, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  messages::declareKeyOption(cli, &key_file);
  cli.options(&options);
  // Short forms, applied after --config as --set is.
  cli.alias("--rate", "max_rate_hz", "HZ");
  cli.alias("--max-places", "max_places", "N");
  cli.check([&options, &read_only, &store_file]() -> Status {
    if (read_only && store_file.empty()) return Error("--read-only needs --store MAP.db");
    return options.validate();
  });
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  cli.logChangedOptions();
  auto vocabulary = bow::loadAnyVocabulary(vocab_file);
  if (!vocabulary) {
    std::fprintf(stderr, "evermap-loopclose-proc: %s\n", vocabulary.error().message.c_str());
    return 1;
  }
  auto store = openStore(store_file, read_only, *vocabulary);
  if (!store) {
    std::fprintf(stderr, "evermap-loopclose-proc: %s\n", store.error().message.c_str());
    return 1;
  }
  const std::unique_ptr<FrameRegistration> registration = makeRegistration();
  if (!registration) {
    std::fprintf(stderr, "evermap-loopclose-proc: invalid default registration options\n");
    return 1;
  }
  auto loop_closer = LoopCloser::create(*vocabulary, *registration, options, std::move(*store));
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
  auto signer = messages::makeSigner("evermap-loopclose-proc", key_file);
  if (!signer) {
    std::fprintf(stderr, "evermap-loopclose-proc: %s\n", signer.error().message.c_str());
    return 2;
  }
  messages::Inbox::Options input = LoopCloseServer::defaultInput();
  input.signer = *signer;
  LoopCloseServer server(lcm, **loop_closer, input);
  std::printf("loopclose-proc: vocabulary %s (%zu words), %zu nodes loaded, registration: %s\n",
              vocab_file.c_str(), vocabulary->numWords(), (*loop_closer)->numNodes(),
              registration->describe().c_str());
  std::fflush(stdout);

  evermap::StopSignals stop;  // SIGINT/SIGTERM, polled between LCM waits
  while (!stop.requested()) {
    if (lcm.handleTimeout(200) < 0) {
      std::fprintf(stderr, "evermap-loopclose-proc: LCM failed\n");
      break;
    }
    server.inbox().publishStatsEvery(1.0);
  }
  std::printf("loopclose-proc: input: %s\n", server.inbox().summary().c_str());
  std::printf("loopclose-proc: %s; %lld messages dropped, %lld results published\n",
              (*loop_closer)->stats().text().c_str(), static_cast<long long>(server.dropped()),
              static_cast<long long>(server.published()));
  std::printf("loopclose-proc: %s\n", (*loop_closer)->recoveryStats().text().c_str());
  return 0;
}
