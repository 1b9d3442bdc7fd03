// evermap-vocab-train: trains a vocabulary tree (core/bow) from folders of images and writes it
// in evermap's vocabulary format. Features are OpenCV ORB for now
// (tools/vocab-train/image_features.h). Exit status: 0 done, 1 bad input (the message names it), 2
// bad command line.

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "core/bow/vocabulary_io.h"
#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "tools/vocab-train/image_training.h"

namespace {

using namespace evermap;
using namespace evermap::bow;

// The training's settings (--help lists them, --print-config prints them).
struct VocabTrainOptions {
  ImageTrainingOptions training;

  void declareOptions(OptionList& o) { o.nest("", &training); }
};

struct Command {
  std::string out;
  std::vector<std::filesystem::path> folders;
  VocabTrainOptions tool;
};

// Returns -1 to run, or main's exit status.
int parse(int argc, char** argv, Command* c) {
  std::vector<std::string> folders;
  CommandLine cli("evermap-vocab-train",
                  "Trains a vocabulary tree from folders of images (png, jpg, bmp, pgm, ...).");
  cli.positional(&folders, "FOLDER...", "folders of images, all used");
  cli.value("--out", &c->out, "FILE.evoc", "the vocabulary to write", /*required=*/true);
  cli.value(
      "--default-data",
      [c](const std::string& dir) -> Status {
        const auto found = defaultTrainingFolders(dir);
        if (found.empty()) return makeError("no default training folder under ", dir);
        c->folders.insert(c->folders.end(), found.begin(), found.end());
        return Ok{};
      },
      "DIR",
      "add the default training folders under DIR (KITTI 07 and 01, EuRoC V1_01 cam0, "
      "slambook2 TUM frames)");
  cli.options(&c->tool);
  cli.alias("--k", "k", "N");
  cli.alias("--levels", "levels", "N");
  cli.alias("--iterations", "iterations", "N");
  cli.alias("--seed", "seed", "N");
  cli.alias("--features", "features", "N");
  cli.alias("--image-step", "image_step", "N");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  c->folders.insert(c->folders.end(), folders.begin(), folders.end());
  auto fail = [&](const std::string& why) {
    std::fprintf(stderr, "evermap-vocab-train: %s\n%s", why.c_str(), cli.usage().c_str());
    return 2;
  };
  if (c->folders.empty()) return fail("no image folder given");
  if (Status s = c->tool.training.validate(); !s) return fail(s.error().message);
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  Command command;
  if (const int code = parse(argc, argv, &command); code >= 0) return code;
  const Command* cmd = &command;
  for (const auto& f : cmd->folders) std::printf("folder %s\n", f.c_str());
  // Wall-clock time is only reported to the person running the tool.
  const auto start = std::chrono::steady_clock::now();
  ImageTrainingSummary summary;
  auto vocabulary = trainFromImageFolders(cmd->folders, cmd->tool.training, &summary);
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
