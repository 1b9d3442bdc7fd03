#pragma once
// The --key option every evermap process takes (issue 47, docs/lcm.md "Senders and the key"):
// a file with the shared key, readable by its owner only. Without --key, $EVERMAP_LCM_KEY
// names the file (the deputy's children inherit it); without either, no key: messages go out
// with the sender's identity but no MAC, and nothing is refused for want of one.

#include <string>

#include "core/common/command_line.h"
#include "core/common/expected.h"
#include "core/messages/envelope.h"

namespace evermap::messages {

void declareKeyOption(CommandLine& cli, std::string* key_file);

// This process's Signer: named `process`, with the key of `key_file` (else $EVERMAP_LCM_KEY's,
// else none). An Error names the file and what is wrong with it.
Expected<Signer> makeSigner(const std::string& process, const std::string& key_file);

}  // namespace evermap::messages
