// viewer/lcm_listener.h over memq://: what arrives on LCM reaches the board, STEREO becomes a
// decimated JPEG with the keyframe's features, and bytes that are not a message are counted
// as malformed without touching what the page shows.

#include <gtest/gtest.h>

#include <string>

#include <lcm/lcm-cpp.hpp>
#include <opencv2/core.hpp>

#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "viewer/board.h"
#include "viewer/lcm_listener.h"

namespace evermap::viewer {
namespace {

std::string latest(const Board& board, Topic topic) {
  Board::Seen seen{};
  std::string text;
  while (auto item = board.next(&seen, -1))
    if (item->topic == topic) text = *item->text;
  return text;
}

TEST(ViewerLcmListener, StereoBecomesAScaledJpegWithTheKeyframesFeatures) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  Board board;
  LcmListenerOptions o;
  o.image_period_s = 0.0;
  LcmListener listener(lcm, board, o);

  keyframe_t kf{};
  kf.utime = 1000000;
  kf.num_features = 2;
  kf.keypoints = {{10.0f, 20.0f}, {630.0f, 470.0f}};
  kf.points = {{0, 0, 1}, {0, 0, 1}};
  kf.disparity = {1.0f, 1.0f};
  kf.level = {0, 0};
  kf.descriptors.assign(2, std::vector<uint8_t>(32, 0));
  lcm.publish(channels::kKeyframe, &kf);
  messages::StereoFrame frame;
  frame.utime = 1000000;
  frame.rectified = true;
  frame.left = cv::Mat(480, 640, CV_8UC1, cv::Scalar(128));
  frame.right = frame.left.clone();
  auto stereo = messages::toMsg(frame, messages::ImageEncoding::kGray8);
  ASSERT_TRUE(stereo);
  lcm.publish(channels::kStereo, &*stereo);
  for (int k = 0; k < 2; ++k) ASSERT_GE(lcm.handleTimeout(1000), 1);

  const std::string image = latest(board, Topic::kImage);
  ASSERT_FALSE(image.empty()) << listener.inbox().summary();
  EXPECT_NE(image.find("\"width\":640,\"height\":480,\"scale\":0.50000,\"jpeg\":\"/9j/"),
            std::string::npos)
      << image.substr(0, 200);
  EXPECT_NE(image.find("\"features_utime\":1000000,\"features\":[10.0,20.0,630.0,470.0]"),
            std::string::npos);
  EXPECT_EQ(listener.imagesSent(), 1);
}

TEST(ViewerLcmListener, BytesThatAreNotAMapGraphAreCountedAndTheMapStays) {
  lcm::LCM lcm("memq://");
  Board board;
  LcmListener listener(lcm, board, {});
  map_graph_t g{};
  g.utime = 5;
  g.nodes.push_back(map_node_t{});
  g.nodes[0].orientation[0] = 1.0;
  g.num_nodes = 1;
  lcm.publish(channels::kMapGraph, &g);
  ASSERT_GE(lcm.handleTimeout(1000), 1);
  const std::string junk(200, '\x7f');
  lcm.publish(channels::kMapGraph, junk.data(), static_cast<unsigned>(junk.size()));
  ASSERT_GE(lcm.handleTimeout(1000), 1);
  EXPECT_EQ(listener.inbox().counts().at(channels::kMapGraph).malformed, 1);
  EXPECT_EQ(board.version(Topic::kGraph), 1u);
  EXPECT_NE(latest(board, Topic::kGraph).find("\"counts\":{\"nodes\":1,"), std::string::npos);
}

}  // namespace
}  // namespace evermap::viewer
