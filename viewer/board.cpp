#include "viewer/board.h"

namespace evermap::viewer {

const char* topicName(Topic t) {
  switch (t) {
    case Topic::kGraph:
      return "graph";
    case Topic::kPose:
      return "pose";
    case Topic::kFloor:
      return "floor";
    case Topic::kStats:
      return "stats";
    case Topic::kHistory:
      return "history";
    case Topic::kRegister:
      return "register";
    case Topic::kDeputy:
      return "deputy";
    case Topic::kVo:
      return "vo";
    case Topic::kImage:
      return "image";
    case Topic::kViewer:
      return "viewer";
    case Topic::kLog:
      return "log";
    case Topic::kPlans:
      return "plans";
    case Topic::kCount:
      break;
  }
  return "?";
}

void Board::post(Topic topic, std::string text) {
  auto shared = std::make_shared<const std::string>(std::move(text));
  std::lock_guard lock(mutex_);
  Slot& s = slots_[static_cast<int>(topic)];
  ++s.version;
  s.text = std::move(shared);  // the old text lives on while a client still sends it
}

std::optional<Board::Item> Board::next(Seen* seen, int after) const {
  std::lock_guard lock(mutex_);
  for (int k = 1; k <= kTopicCount; ++k) {
    const int t = ((after % kTopicCount) + kTopicCount + k) % kTopicCount;
    const Slot& s = slots_[t];
    uint64_t& have = (*seen)[t];
    if (s.version > have) {
      const uint64_t skipped = have == 0 ? 0 : s.version - have - 1;
      have = s.version;
      return Item{static_cast<Topic>(t), s.version, s.text, skipped};
    }
  }
  return std::nullopt;
}

uint64_t Board::version(Topic topic) const {
  std::lock_guard lock(mutex_);
  return slots_[static_cast<int>(topic)].version;
}

}  // namespace evermap::viewer
