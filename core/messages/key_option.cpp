#include "core/messages/key_option.h"

#include <cstdlib>
#include <memory>

namespace evermap::messages {

void declareKeyOption(CommandLine& cli, std::string* key_file) {
  cli.value("--key", key_file, "FILE",
            "shared LCM key (64 hex digits, mode 600): sign what is sent, refuse what is not "
            "signed with it (default: $EVERMAP_LCM_KEY; none: no MAC)");
}

Expected<Signer> makeSigner(const std::string& process, const std::string& key_file) {
  std::string file = key_file;
  if (file.empty()) {
    if (const char* env = std::getenv("EVERMAP_LCM_KEY"); env && *env) file = env;
  }
  if (file.empty()) return Signer::make(process, nullptr);
  auto key = MacKey::load(file);
  if (!key) return key.error();
  return Signer::make(process, std::make_shared<const MacKey>(*key));
}

}  // namespace evermap::messages
