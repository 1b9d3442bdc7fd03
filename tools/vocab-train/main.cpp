// evermap-vocab-train: trains a vocabulary tree (core/bow) from folders of images and writes it
// in evermap's vocabulary format. Features are OpenCV ORB for now (core/bow/image_features.h).
// Exit status: 0 done, 1 bad input (the message names it), 2 bad command line.

#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "core/bow/image_training.h"
#include "core/bow/vocabulary_io.h"

namespace {

using namespace evermap;
using namespace evermap::bow;

constexpr const char* kUsage =
    "usage: evermap-vocab-train --out FILE.evoc [options] [FOLDER...]\n"
    "  FOLDER...            folders of images (png, jpg, bmp, pgm, ...), all used\n"
    "  --default-data DIR   add evermap's default training folders under DIR (the shared\n"
    "                       data: KITTI 07 and 01, EuRoC V1_01 cam0, slambook2 TUM frames)\n"
    "  --k N                branching factor (default 10)\n"
    "  --levels N           depth L (default 5)\n"
    "  --iterations N       k-majority iterations per node (default 10)\n"
    "  --seed N             k-means++ seed (default 1)\n"
    "  --features N         ORB features per image (default 1000)\n"
    "  --image-step N       use every N-th image of each folder (default 1)\n";

template <typename T>
bool parseNumber(const std::string& s, T* out) {
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), *out);
  return ec == std::errc() && p == s.data() + s.size();
}

struct CommandLine {
  std::string out;
  std::vector<std::filesystem::path> folders;
  ImageTrainingOptions options;
};

std::optional<CommandLine> parse(int argc, char** argv) {
  CommandLine c;
  auto fail = [](const std::string& why) {
    std::fprintf(stderr, "evermap-vocab-train: %s\n%s", why.c_str(), kUsage);
    return std::nullopt;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    }
    if (a.rfind("--", 0) != 0) {
      c.folders.emplace_back(a);
      continue;
    }
    if (i + 1 >= argc) return fail(a + " needs a value");
    const std::string v = argv[++i];
    bool ok = true;
    if (a == "--out") {
      c.out = v;
    } else if (a == "--default-data") {
      const auto folders = defaultTrainingFolders(v);
      if (folders.empty()) return fail("no default training folder under " + v);
      c.folders.insert(c.folders.end(), folders.begin(), folders.end());
    } else if (a == "--k") {
      ok = parseNumber(v, &c.options.tree.branching);
    } else if (a == "--levels") {
      ok = parseNumber(v, &c.options.tree.levels);
    } else if (a == "--iterations") {
      ok = parseNumber(v, &c.options.tree.max_iterations);
    } else if (a == "--seed") {
      ok = parseNumber(v, &c.options.tree.seed);
    } else if (a == "--features") {
      ok = parseNumber(v, &c.options.orb.max_features);
    } else if (a == "--image-step") {
      ok = parseNumber(v, &c.options.image_step);
    } else {
      return fail("unknown option " + a);
    }
    if (!ok) return fail("bad value for " + a + ": " + v);
  }
  if (c.out.empty()) return fail("--out is required");
  if (c.folders.empty()) return fail("no image folder given");
  if (std::string why = c.options.validate(); !why.empty()) return fail(why);
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  const auto cmd = parse(argc, argv);
  if (!cmd) return 2;
  for (const auto& f : cmd->folders) std::printf("folder %s\n", f.c_str());
  // Wall-clock time is only reported to the person running the tool.
  const auto start = std::chrono::steady_clock::now();
  ImageTrainingSummary summary;
  auto vocabulary = trainFromImageFolders(cmd->folders, cmd->options, &summary);
  if (!vocabulary) {
    std::fprintf(stderr, "evermap-vocab-train: %s\n", vocabulary.error().message.c_str());
    return 1;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (Status s = saveVocabulary(*vocabulary, cmd->out); !s) {
    std::fprintf(stderr, "evermap-vocab-train: %s\n", s.error().message.c_str());
    return 1;
  }
  std::printf("%s\n", summary.message.c_str());
  std::printf("words per depth:");
  for (size_t d = 0; d < summary.tree.words_per_depth.size(); ++d) {
    std::printf(" %zu:%zu", d, summary.tree.words_per_depth[d]);
  }
  std::printf("\nfingerprint %016llx, trained in %.1f s, written to %s\n",
              static_cast<unsigned long long>(vocabulary->fingerprint()), seconds,
              cmd->out.c_str());
  return 0;
}
