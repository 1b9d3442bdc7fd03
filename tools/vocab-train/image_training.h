#pragma once
// Training a vocabulary from folders of images: ORB features of every image (image_features.h,
// OpenCV's ORB for now), then vocabulary_training.h. Used by evermap-vocab-train, the tests
// and the demo. The project's vocabulary is trained at run time from the image simulator's
// renders (scripts/make-vocab.sh); the one from real images (defaultTrainingFolders) needs the
// shared data. A trained vocabulary is a derived file and is never committed.

#include <filesystem>
#include <string>
#include <vector>

#include "core/bow/vocabulary.h"
#include "core/common/expected.h"
#include "tools/vocab-train/image_features.h"
#include "tools/vocab-train/vocabulary_training.h"

namespace evermap::bow {

struct ImageTrainingOptions {
  OrbOptions orb;
  TrainingOptions tree;
  int image_step = 1;  // consecutive video frames add little

  void declareOptions(OptionList& o);
  Status validate() const { return checkOptionRanges(*this); }
};

struct ImageTrainingSummary {
  std::vector<std::filesystem::path> images;  // in the order used
  TrainingSummary tree;
  std::string message;
};

Expected<Vocabulary> trainFromImageFolders(const std::vector<std::filesystem::path>& folders,
                                           const ImageTrainingOptions& options,
                                           ImageTrainingSummary* summary = nullptr);

// The image folders of the shared data that make evermap's default vocabulary: outdoor
// street scenes (KITTI 07 and 01), an indoor flying sequence (EuRoC V1_01) and indoor desk
// scenes (the 10 TUM-like frames of slambook2). The rtabmap-lcd-samples images are left out
// on purpose: they are the place-recognition test set. Folders that are missing are skipped;
// the result is empty when none is there.
std::vector<std::filesystem::path> defaultTrainingFolders(const std::filesystem::path& data_root);

}  // namespace evermap::bow
