// Reading DBoW2/DBoW3 vocabularies from OpenCV FileStorage YAML (vocabulary_io.h has the
// layout). cv::FileStorage reads ".gz" files directly.

#include <opencv2/core/persistence.hpp>

#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/bow/vocabulary_io.h"

namespace evermap::bow {

namespace {

// DBoW2 FORB: "b0 b1 ... b31"; DBoW3: "type cols b0 ... b31" with type 0 (CV_8U), cols 32.
Expected<Descriptor> parseDescriptor(const std::string& text, const std::string& where) {
  std::istringstream in(text);
  std::vector<long> values;
  long v = 0;
  while (in >> v) values.push_back(v);
  if (!in.eof()) return makeError(where, ": descriptor \"", text, "\" is not a list of numbers");
  size_t first = 0;
  if (values.size() == kDescriptorBytes + 2) {
    if (values[0] != CV_8U || values[1] != kDescriptorBytes) {
      return makeError(where, ": DBoW3 descriptor of type ", values[0], " with ", values[1],
                       " columns; only 32-byte CV_8U (ORB) descriptors are supported");
    }
    first = 2;
  } else if (values.size() != kDescriptorBytes) {
    return makeError(where, ": descriptor has ", values.size(),
                     " numbers; expected 32 (DBoW2 ORB) or 34 (DBoW3 ORB)");
  }
  Descriptor d;
  for (size_t i = 0; i < kDescriptorBytes; ++i) {
    const long b = values[first + i];
    if (b < 0 || b > 255) return makeError(where, ": descriptor byte ", b, " is not in 0..255");
    d.bytes[i] = static_cast<uint8_t>(b);
  }
  return d;
}

Expected<int> readInt(const cv::FileNode& parent, const char* key, const std::string& where) {
  const cv::FileNode n = parent[key];
  if (n.empty() || !n.isInt()) return makeError(where, ": missing or non-integer '", key, "'");
  return static_cast<int>(n);
}

Expected<Vocabulary> parse(const cv::FileStorage& fs, const std::string& name) {
  const cv::FileNode voc = fs["vocabulary"];
  if (voc.empty() || !voc.isMap()) {
    return makeError(name, ": no 'vocabulary' map (not a DBoW2/DBoW3 vocabulary)");
  }
  auto k = readInt(voc, "k", name);
  if (!k) return k.error();
  auto levels = readInt(voc, "L", name);
  if (!levels) return levels.error();
  auto scoring = readInt(voc, "scoringType", name);
  if (!scoring) return scoring.error();
  auto weighting = readInt(voc, "weightingType", name);
  if (!weighting) return weighting.error();
  if (*weighting != 0 || *scoring != 0) {
    return makeError(name, ": weightingType ", *weighting, " / scoringType ", *scoring,
                     " not supported (evermap implements TF_IDF = 0 with L1_NORM = 0)");
  }
  const cv::FileNode node_seq = voc["nodes"];
  const cv::FileNode word_seq = voc["words"];
  if (!node_seq.isSeq() || !word_seq.isSeq()) {
    return makeError(name, ": 'nodes' and 'words' must be sequences");
  }

  // DBoW node ids are positions in its node array, root 0 implicit; map them to list slots.
  std::vector<NodeSpec> nodes(1);
  std::unordered_map<int64_t, size_t> slot_of_id{{0, 0}};
  std::vector<int64_t> parent_id(1, -1);
  int index = 0;
  for (auto it = node_seq.begin(); it != node_seq.end(); ++it, ++index) {
    const cv::FileNode n = *it;
    const std::string where = name + ": nodes[" + std::to_string(index) + "]";
    auto id = readInt(n, "nodeId", where);
    if (!id) return id.error();
    auto parent = readInt(n, "parentId", where);
    if (!parent) return parent.error();
    const cv::FileNode w = n["weight"];
    const cv::FileNode d = n["descriptor"];
    if (w.empty() || (!w.isReal() && !w.isInt())) {
      return makeError(where, ": missing or non-numeric 'weight'");
    }
    if (d.empty() || !d.isString()) return makeError(where, ": missing 'descriptor' string");
    if (*id <= 0 || !slot_of_id.emplace(*id, nodes.size()).second) {
      return makeError(where, ": nodeId ", *id, " is not positive or appears twice");
    }
    auto descriptor = parseDescriptor(static_cast<std::string>(d), where);
    if (!descriptor) return descriptor.error();
    NodeSpec spec;
    spec.descriptor = *descriptor;
    spec.weight = static_cast<double>(w);
    nodes.push_back(spec);
    parent_id.push_back(*parent);
  }
  for (size_t i = 1; i < nodes.size(); ++i) {
    auto p = slot_of_id.find(parent_id[i]);
    if (p == slot_of_id.end()) {
      return makeError(name, ": nodes[", i - 1, "] has parentId ", parent_id[i],
                       ", which is not a node");
    }
    nodes[i].parent = static_cast<int64_t>(p->second);
  }
  index = 0;
  for (auto it = word_seq.begin(); it != word_seq.end(); ++it, ++index) {
    const std::string where = name + ": words[" + std::to_string(index) + "]";
    auto word = readInt(*it, "wordId", where);
    if (!word) return word.error();
    auto node = readInt(*it, "nodeId", where);
    if (!node) return node.error();
    auto s = slot_of_id.find(*node);
    if (s == slot_of_id.end() || s->second == 0) {
      return makeError(where, ": nodeId ", *node, " is not a node");
    }
    if (*word < 0 || nodes[s->second].word >= 0) {
      return makeError(where, ": wordId ", *word, " is negative or its node already has a word");
    }
    nodes[s->second].word = *word;
  }
  return Vocabulary::create(*k, *levels, std::move(nodes), name);
}

}  // namespace

Expected<Vocabulary> loadDbowYaml(const std::filesystem::path& file) {
  const std::string name = file.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return makeError(name, ": no such file");
  try {
    cv::FileStorage fs(name, cv::FileStorage::READ | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) return makeError(name, ": cannot be read as OpenCV YAML");
    return parse(fs, name);
  } catch (const cv::Exception& e) {
    // OpenCV's parser puts "file(line): what" in `func` and its own function name in `err`;
    // what() spans lines and names OpenCV's source file. Keep the two short parts.
    std::string what = e.err;
    if (!e.func.empty()) what += (what.empty() ? "" : ": ") + e.func;
    if (what.empty()) what = e.what();
    for (char& c : what) {
      if (c == '\n') c = ' ';
    }
    return makeError(name, ": not a valid OpenCV YAML file (", what, ")");
  }
}

}  // namespace evermap::bow
