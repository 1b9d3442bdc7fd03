// tools/eval/evaluation and report: the whole pipeline on synthetic and real trajectories, and
// the JSON it writes parsed back by a strict reader.
#include <gtest/gtest.h>

#include <cctype>
#include <fstream>
#include <map>
#include <sstream>

#include "eval_synthetic.h"
#include "scratch_dir.h"
#include "test_data.h"
#include "tools/eval/report.h"

namespace evermap::eval {
namespace {

// A strict JSON reader (RFC 8259) that flattens a document into "a.b.0.c" -> scalar text.
// Fails the test on any syntax error, so the report must be valid JSON, not just look like it.
class FlatJson {
 public:
  explicit FlatJson(const std::string& text) : s_(text) {
    skipSpace();
    value("");
    skipSpace();
    ok_ = ok_ && i_ == s_.size();
  }
  bool ok() const { return ok_; }
  bool has(const std::string& key) const { return values_.count(key) > 0; }
  double number(const std::string& key) const {
    auto it = values_.find(key);
    return it == values_.end() ? std::nan("") : std::strtod(it->second.c_str(), nullptr);
  }
  std::string text(const std::string& key) const {
    auto it = values_.find(key);
    return it == values_.end() ? "<missing>" : it->second;
  }

 private:
  void skipSpace() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
  }
  bool eat(char c) {
    skipSpace();
    if (i_ < s_.size() && s_[i_] == c) {
      ++i_;
      return true;
    }
    return false;
  }
  std::string str() {
    std::string out;
    if (!eat('"')) return fail();
    while (i_ < s_.size() && s_[i_] != '"') {
      if (static_cast<unsigned char>(s_[i_]) < 0x20) return fail();
      if (s_[i_] == '\\') {
        ++i_;
        if (i_ >= s_.size() || std::string("\"\\/bfnrtu").find(s_[i_]) == std::string::npos) {
          return fail();
        }
        if (s_[i_] == 'u') i_ += 4;
      }
      out += s_[i_++];
    }
    if (i_ >= s_.size()) return fail();
    ++i_;
    return out;
  }
  std::string fail() {
    ok_ = false;
    i_ = s_.size();
    return "";
  }
  void value(const std::string& path) {
    skipSpace();
    if (!ok_ || i_ >= s_.size()) {
      fail();
      return;
    }
    const std::string prefix = path.empty() ? "" : path + ".";
    if (s_[i_] == '{') {
      ++i_;
      if (eat('}')) return;
      do {
        const std::string key = str();
        if (!eat(':')) fail();
        value(prefix + key);
      } while (ok_ && eat(','));
      if (!eat('}')) fail();
    } else if (s_[i_] == '[') {
      ++i_;
      if (eat(']')) return;
      int k = 0;
      do value(prefix + std::to_string(k++));
      while (ok_ && eat(','));
      if (!eat(']')) fail();
    } else if (s_[i_] == '"') {
      values_[path] = str();
    } else {
      const size_t b = i_;
      while (i_ < s_.size() &&
             std::string("+-.eE0123456789truefalsn").find(s_[i_]) != std::string::npos)
        ++i_;
      const std::string tok = s_.substr(b, i_ - b);
      char* end = nullptr;
      std::strtod(tok.c_str(), &end);
      const bool is_number = !tok.empty() && end == tok.c_str() + tok.size() && tok[0] != '+' &&
                             tok.find_first_of("ntf") == std::string::npos;
      if (!is_number && tok != "true" && tok != "false" && tok != "null") fail();
      values_[path] = tok;
    }
  }
  std::string s_;
  size_t i_ = 0;
  bool ok_ = true;
  std::map<std::string, std::string> values_;
};

TEST(FlatJsonReader, RejectsInvalidDocuments) {
  EXPECT_TRUE(FlatJson("{\"a\": [1, 2.5e-3, null, true], \"b\": {\"c\": \"x\\\"y\"}}").ok());
  EXPECT_FALSE(FlatJson("{\"a\": 1,}").ok());
  EXPECT_FALSE(FlatJson("{\"a\": nan}").ok());
  EXPECT_FALSE(FlatJson("{\"a\": 1} x").ok());
  EXPECT_FALSE(FlatJson("{\"a\": \"tab\there\"}").ok());
}

TEST(Evaluation, RecoversAKnownSim3AndReportsItInValidJson) {
  const Trajectory gt = testing::syntheticTrajectory(300, 0, "gt \"quoted\".txt");
  Trajectory est = gt;
  est.source = "est.txt";
  // The estimate lives in its own frame, at half scale, with stamps 3 ms late.
  core::Vec6 xi;
  xi << 1.0, 2.0, -3.0, 0.2, -0.4, 0.9;
  const core::SE3d est_T_gt = core::SE3d::exp(xi);
  for (StampedPose& p : est.poses) {
    p.t_ns += 3000000;
    p.world_T_body = core::SE3d(est_T_gt.so3() * p.world_T_body.so3(),
                                0.5 * (est_T_gt * p.world_T_body.translation()));
  }
  EvaluationOptions options;
  options.alignment = AlignmentMode::kSim3;
  options.rpe = {.delta_frames = 5};
  const auto r = evaluate(gt, est, options);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->pairs, 300u);
  EXPECT_NEAR(r->max_abs_dt_s, 0.003, 1e-12);
  EXPECT_NEAR(r->alignment.gt_S_est.scale, 2.0, 1e-12);
  EXPECT_LT(r->ate.translation_m.rmse, 1e-9);
  EXPECT_LT(r->ate.rotation_deg.max, 1e-9);
  EXPECT_LT(r->rpe.translation_m.max, 1e-9);
  EXPECT_NEAR(r->gt_path_m, r->est_path_m, 1e-9);
  EXPECT_EQ(r->est_positions_aligned.size(), 300u);

  const FlatJson json(formatJson(*r));
  ASSERT_TRUE(json.ok()) << formatJson(*r);
  EXPECT_EQ(json.text("ground_truth.file"), "gt \"quoted\".txt");
  EXPECT_EQ(json.text("alignment.mode"), "sim3");
  EXPECT_NEAR(json.number("alignment.scale"), 2.0, 1e-9);
  EXPECT_EQ(json.number("association.pairs"), 300);
  EXPECT_EQ(json.number("rpe.delta_frames"), 5);
  for (const char* key :
       {"ate.translation_m", "ate.rotation_deg", "rpe.translation_m", "rpe.rotation_deg"}) {
    for (const char* stat : {"count", "rmse", "mean", "median", "std", "min", "max"}) {
      EXPECT_TRUE(json.has(std::string(key) + "." + stat)) << key << "." << stat;
    }
  }
  EXPECT_TRUE(json.has("alignment.rotation_wxyz.3"));
  EXPECT_TRUE(json.has("alignment.translation_m.2"));
  EXPECT_FALSE(json.has("kitti_drift.segments"));
  EXPECT_NE(formatText(*r).find("ATE"), std::string::npos);
}

TEST(Evaluation, TooFewPairsForAlignmentIsAnErrorNamingTheFiles) {
  const Trajectory gt = testing::syntheticTrajectory(2, 0, "gt.txt");
  const Trajectory est = testing::syntheticTrajectory(2, 0, "est.txt");
  const auto r = evaluate(gt, est, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("est.txt against gt.txt"), std::string::npos)
      << r.error().message;
  EXPECT_NE(r.error().message.find("at least 3"), std::string::npos) << r.error().message;
}

TEST(Evaluation, KittiSequenceAgainstAPerturbedCopy) {
  EVERMAP_REQUIRE_DATA(dir, "kitti-gt-poses");
  const auto gt = readKitti(dir / "07.txt");
  ASSERT_TRUE(gt.ok()) << gt.error().message;
  // The copy is 2 % too long: positions scaled about the start.
  Trajectory est = *gt;
  est.source = "07 scaled";
  for (StampedPose& p : est.poses) {
    p.world_T_body = core::SE3d(p.world_T_body.so3(), 1.02 * p.world_T_body.translation());
  }
  EvaluationOptions options;
  options.alignment = AlignmentMode::kNone;
  options.kitti_drift = true;
  auto r = evaluate(*gt, est, options);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_NEAR(r->gt_path_m, 694.7, 0.1);  // SOURCE.txt: 695 m
  // Each segment's error is 2 % of its end-to-end displacement, at most 2 % of its length.
  EXPECT_GT(r->drift->translation_percent, 1.0);
  EXPECT_LE(r->drift->translation_percent, 2.0);
  EXPECT_LT(r->drift->rotation_deg_per_100m, 1e-9);
  EXPECT_EQ(r->drift->per_length.back().segments, 0u);  // 800 m > 695 m
  const FlatJson json(formatJson(*r));
  ASSERT_TRUE(json.ok());
  EXPECT_TRUE(json.has("kitti_drift.per_length.0.translation_percent"));
  EXPECT_NEAR(json.number("kitti_drift.translation_percent"), r->drift->translation_percent, 1e-6);

  // Sim(3) alignment removes the scale error completely.
  options.alignment = AlignmentMode::kSim3;
  r = evaluate(*gt, est, options);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->alignment.gt_S_est.scale, 1.0 / 1.02, 1e-9);
  EXPECT_LT(r->drift->translation_percent, 1e-6);
  EXPECT_LT(r->ate.translation_m.max, 1e-6);
}

TEST(Evaluation, JsonIsWrittenThroughATemporaryFile) {
  const Trajectory gt = testing::syntheticTrajectory(50);
  const auto r = evaluate(gt, gt, {});
  ASSERT_TRUE(r.ok());
  const evermap::testing::ScratchDir dir;
  ASSERT_TRUE(writeJson(*r, dir / "out.json").ok());
  std::ifstream in(dir / "out.json");
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_TRUE(FlatJson(ss.str()).ok());
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()),
                          std::filesystem::directory_iterator()),
            1);
}

}  // namespace
}  // namespace evermap::eval

namespace evermap::eval {
namespace {

TEST(Evaluation, FigureShowsOnlyTheGroundTruthTheEstimateCovers) {
  const Trajectory gt = testing::syntheticTrajectory(200, 1000000000LL, "gt.txt");
  Trajectory est{"est.txt", {gt.poses.begin() + 50, gt.poses.begin() + 120}};
  const auto r = evaluate(gt, est, {});
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->gt_positions.size(), 70u);
  EXPECT_EQ(r->est_positions_aligned.size(), 70u);
  EXPECT_NEAR((r->gt_positions.front() - gt.poses[50].world_T_body.translation()).norm(), 0.0,
              1e-12);
}

}  // namespace
}  // namespace evermap::eval
