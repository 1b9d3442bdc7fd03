#include "tools/vocab-train/image_training.h"

namespace evermap::bow {

void ImageTrainingOptions::declareOptions(OptionList& o) {
  o.nest("", &tree);
  o.nest("", &orb);
  o.add("image_step", &image_step, "", "use every N-th image of each folder").min(1);
}

Expected<Vocabulary> trainFromImageFolders(const std::vector<std::filesystem::path>& folders,
                                           const ImageTrainingOptions& options,
                                           ImageTrainingSummary* summary) {
  if (Status s = options.validate(); !s) {
    return makeError("vocabulary training options: ", s.error().message);
  }
  if (folders.empty()) return makeError("vocabulary training: no image folder given");
  ImageTrainingSummary s;
  std::vector<std::vector<Descriptor>> per_image;
  for (const auto& folder : folders) {
    auto files = listImages(folder);
    if (!files) return files.error();
    for (size_t i = 0; i < files->size(); i += static_cast<size_t>(options.image_step)) {
      auto features = extractOrbFromFile((*files)[i], options.orb);
      if (!features) return features.error();
      per_image.push_back(std::move(features->descriptors));
      s.images.push_back((*files)[i]);
    }
  }
  auto vocabulary = trainVocabulary(per_image, options.tree, &s.tree);
  if (!vocabulary) return vocabulary.error();
  s.message = s.tree.message + " (ORB: " + std::to_string(options.orb.max_features) +
              " features per image, " + std::to_string(folders.size()) + " folders)";
  if (summary) *summary = std::move(s);
  return vocabulary;
}

std::vector<std::filesystem::path> defaultTrainingFolders(const std::filesystem::path& root) {
  const std::filesystem::path candidates[] = {
      root / "kitti07-mono-160" / "image_0",
      root / "kitti-mono-snippet" / "image_l",
      root / "euroc-v101-micro" / "mav0" / "cam0" / "data",
      root / "vocab-orb-small" / "slambook2_ch11_tum_images",
  };
  std::vector<std::filesystem::path> out;
  std::error_code ec;
  for (const auto& c : candidates) {
    if (std::filesystem::is_directory(c, ec)) out.push_back(c);
  }
  return out;
}

}  // namespace evermap::bow
