#include "core/bow/descriptor.h"

#include <string>

namespace evermap::bow {

Expected<std::vector<Descriptor>> descriptorsFromMat(const cv::Mat& mat, const char* what) {
  std::vector<Descriptor> out;
  if (mat.empty()) return out;
  if (mat.type() != CV_8UC1 || mat.cols != kDescriptorBytes) {
    return makeError(what, ": descriptors must be CV_8UC1 with ", kDescriptorBytes,
                     " columns (256-bit binary), got type ", mat.type(), " with ", mat.cols,
                     " columns");
  }
  out.resize(static_cast<size_t>(mat.rows));
  for (int r = 0; r < mat.rows; ++r) {
    std::memcpy(out[static_cast<size_t>(r)].bytes.data(), mat.ptr<uint8_t>(r), kDescriptorBytes);
  }
  return out;
}

cv::Mat descriptorsToMat(const std::vector<Descriptor>& descriptors) {
  cv::Mat mat(static_cast<int>(descriptors.size()), kDescriptorBytes, CV_8UC1);
  for (int r = 0; r < mat.rows; ++r) {
    std::memcpy(mat.ptr<uint8_t>(r), descriptors[static_cast<size_t>(r)].bytes.data(),
                kDescriptorBytes);
  }
  return mat;
}

Descriptor descriptorFromBytes(const uint8_t* bytes) {
  Descriptor d;
  std::memcpy(d.bytes.data(), bytes, kDescriptorBytes);
  return d;
}

}  // namespace evermap::bow
