#include "core/messages/wire_check.h"

#include <string>
#include <vector>

namespace evermap::messages {
namespace {

using wire::Kind;

// LCM encodes integers big-endian, two's complement (lcm_coretypes.h).
int64_t readInteger(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int k = 0; k < bytes; ++k) v = (v << 8) | p[k];
  const int shift = 64 - 8 * bytes;
  return shift == 0 ? static_cast<int64_t>(v) : static_cast<int64_t>(v << shift) >> shift;
}

class Walker {
 public:
  Walker(const uint8_t* buf, int64_t size, const char* root)
      : buf_(buf), size_(size), root_(root) {}

  // Walks one struct starting at pos_; false with error_ set when the buffer cannot hold it.
  // The member's path ("map_graph_t.nodes[12].position") is spelled only for an error: a
  // string per member made a 56,000-node MAP_GRAPH cost a million allocations.
  bool walk(int type) {
    const wire::Type& t = wire::kTypes[type];
    int64_t values[64] = {};  // integer members read so far (dimensions refer to them)
    for (int i = 0; i < t.num_members; ++i) {
      const wire::Member& m = t.members[i];
      trail_.push_back({m.name, -1});
      const NameOnError name;
      // The element count. A length read from the message must not exceed the bytes left:
      // the decoder allocates it (the outer vectors) before reading, and any element of an
      // honest array takes at least one byte. Then, unless some dimension is zero, the count
      // itself must fit the bytes left, for the same reason (checked as it grows: no overflow).
      int64_t dims[4] = {};
      bool empty = false;
      for (int d = 0; d < m.num_dims; ++d) {
        const wire::Dim& dim = m.dims[d];
        const int64_t n = dim.member < 0 ? dim.length : values[dim.member];
        if (dim.member >= 0 && n < 0) {
          return fail(name, ": length ", n, " (", t.members[dim.member].name, ") is negative");
        }
        if (dim.member >= 0 && n > left()) {
          return fail(name, ": length ", n, " (", t.members[dim.member].name, ") exceeds the ",
                      left(), " bytes left");
        }
        dims[d] = n;
        empty = empty || n == 0;
      }
      int64_t count = empty ? 0 : 1;
      for (int d = 0; d < m.num_dims && !empty; ++d) {
        count *= dims[d];
        if (count > left())
          return fail(name, ": ", count, " elements exceed the ", left(), " bytes left");
      }
      if (m.kind == Kind::kStruct) {
        for (int64_t e = 0; e < count; ++e) {
          if (m.num_dims) trail_.back().index = e;
          if (!walk(m.type)) return false;
        }
      } else if (m.kind == Kind::kString) {
        for (int64_t e = 0; e < count; ++e) {
          if (left() < 4) return fail(name, ": truncated string length");
          // LCM writes strlen + 1 (the terminating NUL is on the wire).
          const int64_t n = readInteger(buf_ + pos_, 4);
          pos_ += 4;
          if (n < 1 || n > left()) {
            return fail(name, ": string length ", n, " outside [1, ", left(), "] bytes left");
          }
          pos_ += n;
        }
      } else {
        const int64_t bytes = count * m.size;  // count <= size_, m.size <= 8: no overflow
        if (bytes > left()) return fail(name, ": ", bytes, " bytes needed, ", left(), " left");
        if (m.num_dims == 0 && m.kind != Kind::kFloat && m.kind != Kind::kDouble) {
          values[i] = readInteger(buf_ + pos_, m.size);
        }
        pos_ += bytes;
      }
      trail_.pop_back();
    }
    return true;
  }

  // Stands for the current member's path in fail()'s arguments.
  struct NameOnError {};
  std::string path() const {
    std::string s = root_;
    for (const Step& step : trail_) {
      s += '.';
      s += step.name;
      if (step.index >= 0) s += "[" + std::to_string(step.index) + "]";
    }
    return s;
  }

  template <typename... Args>
  bool fail(NameOnError, Args&&... args) {
    error_ = makeError(path(), std::forward<Args>(args)...);
    return false;
  }

  int64_t left() const { return size_ - pos_; }
  int64_t pos_ = 0;
  Error error_;

 private:
  struct Step {
    const char* name;
    int64_t index;  // the element of an array of structs; -1: none
  };
  const uint8_t* buf_;
  int64_t size_;
  const char* root_;
  std::vector<Step> trail_;  // the members being walked, outermost first
};

}  // namespace

Expected<int64_t> checkWire(int type, int64_t hash, const void* data, int64_t size) {
  const char* name = wire::kTypes[type].name;
  if (data == nullptr || size < 8) return makeError(name, ": ", size, " bytes hold no type hash");
  Walker w(static_cast<const uint8_t*>(data), size, name);
  const int64_t got = readInteger(static_cast<const uint8_t*>(data), 8);
  if (got != hash) return makeError("not a ", name, " (type hash ", got, ", expected ", hash, ")");
  w.pos_ = 8;
  if (!w.walk(type)) return w.error_;
  return w.pos_;
}

std::optional<int64_t> leadingUtime(const void* data, int64_t size) {
  if (data == nullptr || size < 16) return std::nullopt;
  return readInteger(static_cast<const uint8_t*>(data) + 8, 8);
}

}  // namespace evermap::messages
