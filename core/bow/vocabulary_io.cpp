#include "core/bow/vocabulary_io.h"

#include <bit>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "core/bow/fnv.h"
#include "core/common/atomic_write.h"

namespace evermap::bow {

namespace {

constexpr char kMagic[8] = {'E', 'V', 'M', 'V', 'O', 'C', '\r', '\n'};
constexpr size_t kHeaderBytes = 40;
constexpr size_t kNodeBytes = 48;

void putU32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}
void putU64(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}
uint32_t getU32(const std::string& in, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i)
    v |= static_cast<uint32_t>(static_cast<uint8_t>(in[at + i])) << (8 * i);
  return v;
}
uint64_t getU64(const std::string& in, size_t at) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i)
    v |= static_cast<uint64_t>(static_cast<uint8_t>(in[at + i])) << (8 * i);
  return v;
}

Expected<std::string> readWholeFile(const std::filesystem::path& file) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) {
    return makeError(file.string(), ": no such file");
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) return makeError(file.string(), ": cannot open for reading");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return makeError(file.string(), ": read failed");
  return ss.str();
}

}  // namespace

Status saveVocabulary(const Vocabulary& v, const std::filesystem::path& file) {
  std::string out;
  out.reserve(kHeaderBytes + kNodeBytes * v.numNodes() + 8);
  out.append(kMagic, sizeof(kMagic));
  putU32(out, kVocabularyFormatVersion);
  putU32(out, static_cast<uint32_t>(v.branching()));
  putU32(out, static_cast<uint32_t>(v.levels()));
  putU32(out, 0);  // tf-idf
  putU32(out, 0);  // L1
  putU32(out, kDescriptorBytes);
  putU64(out, v.numNodes());
  for (uint32_t n = 0; n < v.numNodes(); ++n) {
    putU32(out, v.parent(n));
    const int64_t word = v.wordOfNode(n);
    putU32(out, static_cast<uint32_t>(static_cast<int32_t>(word)));
    putU64(out, std::bit_cast<uint64_t>(word >= 0 ? v.weight(static_cast<uint32_t>(word)) : 0.0));
    out.append(reinterpret_cast<const char*>(v.descriptor(n).bytes.data()), kDescriptorBytes);
  }
  Fnv1a64 h;
  h.addBytes(out.data(), out.size());
  putU64(out, h.value());
  return writeFileAtomically(file, out);
}

Expected<Vocabulary> loadVocabulary(const std::filesystem::path& file) {
  auto bytes = readWholeFile(file);
  if (!bytes) return bytes.error();
  const std::string& in = *bytes;
  const std::string name = file.string();
  if (in.size() < sizeof(kMagic) || std::memcmp(in.data(), kMagic, sizeof(kMagic)) != 0) {
    return makeError(name,
                     ": not an evermap vocabulary file (bad magic; a DBoW2/DBoW3 .yml.gz "
                     "is read by loadDbowYaml)");
  }
  if (in.size() < kHeaderBytes + 8) {
    return makeError(name, ": truncated (", in.size(), " bytes, the header alone is ",
                     kHeaderBytes + 8, ")");
  }
  const uint32_t version = getU32(in, 8);
  if (version != kVocabularyFormatVersion) {
    return makeError(name, ": format version ", version, ", this build reads version ",
                     kVocabularyFormatVersion);
  }
  const uint32_t k = getU32(in, 12), levels = getU32(in, 16);
  const uint32_t weighting = getU32(in, 20), scoring = getU32(in, 24);
  const uint32_t descriptor_bytes = getU32(in, 28);
  const uint64_t num_nodes = getU64(in, 32);
  if (weighting != 0 || scoring != 0) {
    return makeError(name, ": weighting ", weighting, " / scoring ", scoring,
                     " not supported (only tf-idf = 0 with L1 = 0)");
  }
  if (descriptor_bytes != kDescriptorBytes) {
    return makeError(name, ": descriptors of ", descriptor_bytes, " bytes, expected ",
                     kDescriptorBytes);
  }
  if (num_nodes > (in.size() - kHeaderBytes - 8) / kNodeBytes ||
      in.size() != kHeaderBytes + kNodeBytes * num_nodes + 8) {
    return makeError(name, ": ", in.size(), " bytes do not hold the ", num_nodes,
                     " nodes the header announces (truncated or padded file)");
  }
  const size_t body = in.size() - 8;
  Fnv1a64 h;
  h.addBytes(in.data(), body);
  if (h.value() != getU64(in, body)) {
    return makeError(name, ": checksum mismatch (the file is corrupt)");
  }
  std::vector<NodeSpec> nodes(static_cast<size_t>(num_nodes));
  for (size_t n = 0; n < nodes.size(); ++n) {
    const size_t at = kHeaderBytes + kNodeBytes * n;
    const uint32_t parent = getU32(in, at);
    nodes[n].parent = parent == Vocabulary::kNoParent ? -1 : static_cast<int64_t>(parent);
    nodes[n].word = static_cast<int32_t>(getU32(in, at + 4));
    nodes[n].weight = std::bit_cast<double>(getU64(in, at + 8));
    std::memcpy(nodes[n].descriptor.bytes.data(), in.data() + at + 16, kDescriptorBytes);
  }
  return Vocabulary::create(static_cast<int>(k), static_cast<int>(levels), std::move(nodes), name);
}

Expected<Vocabulary> loadAnyVocabulary(const std::filesystem::path& file) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    return makeError(file.string(), ": no such file");
  std::ifstream in(file, std::ios::binary);
  if (!in) return makeError(file.string(), ": cannot open for reading");
  char head[sizeof(kMagic)] = {};
  in.read(head, sizeof(head));
  if (in.gcount() == sizeof(head) && std::memcmp(head, kMagic, sizeof(kMagic)) == 0) {
    return loadVocabulary(file);
  }
  return loadDbowYaml(file);
}

}  // namespace evermap::bow
