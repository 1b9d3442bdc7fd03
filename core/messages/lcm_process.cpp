#include "core/messages/lcm_process.h"

#include <cstdio>
#include <utility>

#include "core/messages/key_option.h"

namespace evermap::messages {

LcmProcess::LcmProcess(std::string name, std::string summary)
    : name_(name), cli_(std::move(name), std::move(summary)) {
  cli_.value("--lcm-url", &url_, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  declareKeyOption(cli_, &key_file_);
}

int LcmProcess::start(int argc, char** argv) {
  cli_.printConfigAlias("--print-options");
  if (const int code = cli_.parseOrExit(argc, argv); code >= 0) return code;
  cli_.logChangedOptions();
  auto signer = makeSigner(name_, key_file_);
  if (!signer) {
    std::fprintf(stderr, "%s: %s\n", name_.c_str(), signer.error().message.c_str());
    return 2;
  }
  signer_ = *signer;
  lcm_.emplace(url_);
  outbox_.emplace(*lcm_, signer_);
  if (lcm_->good()) return -1;
  std::fprintf(stderr, "%s: cannot open LCM \"%s\"\n", name_.c_str(), url_.c_str());
  return 1;
}

Inbox& LcmProcess::inbox(int queue_capacity, double time_window_s) {
  if (!inbox_) {
    Inbox::Options options;
    options.process = name_;
    options.queue_capacity = queue_capacity;
    options.time.window_s = time_window_s;
    options.signer = signer_;
    inbox_.emplace(*lcm_, options);
  }
  return *inbox_;
}

void LcmProcess::run() {
  while (!stop_.requested()) {
    if (lcm_->handleTimeout(200) < 0) break;
    if (inbox_) inbox_->publishStatsEvery(1.0);
  }
  std::fprintf(stderr, "%s: input: %s\n", name_.c_str(), inbox_ ? inbox_->summary().c_str() : "");
}

}  // namespace evermap::messages
