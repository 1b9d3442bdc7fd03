#pragma once
// Vocabulary files.
//
// evermap's own format (".evoc"), little-endian, version 1:
//   offset  0  8 bytes  magic "EVMVOC\r\n" (the CR LF catches text-mode mangling)
//           8  u32      format version (1)
//          12  u32      branching factor k
//          16  u32      depth L
//          20  u32      weighting (0 = tf-idf)    — DBoW2's enum values
//          24  u32      scoring (0 = L1)
//          28  u32      descriptor bytes (32)
//          32  u64      number of nodes N
//          40  N x 48   nodes breadth first, root first:
//                         u32 parent (0xFFFFFFFF for the root), i32 word id (-1: inner node),
//                         f64 idf weight, 32 bytes descriptor
//   40+48N     u64      FNV-1a 64 of every byte before it
// Written to a temporary file and renamed. Loading checks the magic, the version, the sizes,
// the checksum and then the tree itself (Vocabulary::create); each failure is one line naming
// the file.
//
// DBoW2 / DBoW3 vocabularies saved by their `save()` as OpenCV FileStorage YAML (optionally
// gzip'd, ".yml.gz"): a node "vocabulary" with k, L, scoringType, weightingType, a sequence
// `nodes` of {nodeId, parentId, weight, descriptor} (root 0 implicit) and a sequence `words`
// of {wordId, nodeId}. The descriptor string is 32 decimal bytes (DBoW2's FORB) or, in DBoW3,
// "type cols" followed by the bytes. Only ORB-size descriptors, tf-idf and L1 are accepted.

#include <filesystem>

#include "core/bow/vocabulary.h"
#include "core/common/expected.h"

namespace evermap::bow {

inline constexpr uint32_t kVocabularyFormatVersion = 1;

Status saveVocabulary(const Vocabulary& vocabulary, const std::filesystem::path& file);
Expected<Vocabulary> loadVocabulary(const std::filesystem::path& file);

// DBoW2/DBoW3 YAML (.yml, .yaml, .yml.gz, .yaml.gz).
Expected<Vocabulary> loadDbowYaml(const std::filesystem::path& file);

// Either of the above, chosen by the file's first bytes (evermap magic or not).
Expected<Vocabulary> loadAnyVocabulary(const std::filesystem::path& file);

}  // namespace evermap::bow
