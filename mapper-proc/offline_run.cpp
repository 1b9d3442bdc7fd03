#include "mapper-proc/offline_run.h"

#include <algorithm>
#include <chrono>
#include <functional>
#include <deque>
#include <map>
#include <optional>
#include <sstream>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/vo_delta_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/eval/alignment.h"
#include "core/eval/metrics.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "core/sim/registration_oracle.h"
#include "core/sim/run.h"
#include "mapper-proc/map_store.h"

namespace evermap::mapper {
namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5));
  return v[k];
}

// Feeds decoded messages to the mapper and brokers its requests with the oracle.
class Broker final : public sim::MessageSink {
 public:
  Broker(Mapper& mapper, sim::RegistrationOracle& oracle) : mapper_(mapper), oracle_(oracle) {}

  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override {
    ++messages_;
    const int64_t size = static_cast<int64_t>(data.size());
    if (channel == channels::kVoDelta) {
      deliver(messages::decodeLcm<vo_delta_t>(data.data(), size, channel));
    } else if (channel == channels::kWheelOdom) {
      deliver(messages::decodeLcm<wheel_odom_t>(data.data(), size, channel));
    } else if (channel == channels::kAttitude) {
      deliver(messages::decodeLcm<attitude_t>(data.data(), size, channel));
    } else if (channel == channels::kFloor) {
      deliver(messages::decodeLcm<floor_t>(data.data(), size, channel));
    }
    pump();
    if (after_update_) after_update_();
  }
  void setAfterUpdate(std::function<void()> f) { after_update_ = std::move(f); }

  // Called by the simulator's observer when a keyframe's truth is known.
  void keyframeKnown(int64_t utime) {
    known_keyframe_ = std::max(known_keyframe_, utime);
    pump();
  }

  int64_t messages() const { return messages_; }
  int64_t decodeErrors() const { return decode_errors_; }
  int64_t falseMatches() const { return false_matches_; }

 private:
  template <typename Msg>
  void deliver(const Expected<Msg>& msg) {
    if (!msg) {
      ++decode_errors_;
      return;
    }
    (void)apply(*msg);  // drops are counted by the mapper
  }
  Status apply(const vo_delta_t& m) { return mapper_.onVo(m); }
  Status apply(const wheel_odom_t& m) { return mapper_.onWheel(m); }
  Status apply(const attitude_t& m) { return mapper_.onAttitude(m); }
  Status apply(const floor_t& m) { return mapper_.onFloor(m); }

  // Nodes and requests wait until the oracle knows their keyframe; answers may raise new
  // requests (node mode, then global), so this loops until nothing is ready.
  void pump() {
    for (;;) {
      for (auto& n : mapper_.takeNodesAdded()) nodes_.push_back(n);
      for (auto& r : mapper_.takeRequests()) requests_.push_back(r);
      bool progressed = false;
      while (!nodes_.empty() && nodes_.front().keyframe_utime <= known_keyframe_) {
        oracle_.addNode(nodes_.front());
        nodes_.pop_front();
        progressed = true;
      }
      if (!requests_.empty() && requests_.front().keyframe_utime <= known_keyframe_ && nodes_.empty()) {
        const register_request_t r = requests_.front();
        requests_.pop_front();
        const auto answer = oracle_.answerWithTruth(r);
        if (answer.false_match) ++false_matches_;
        (void)mapper_.onRegisterResult(answer.result);
        progressed = true;
      }
      if (!progressed) return;
    }
  }

  Mapper& mapper_;
  sim::RegistrationOracle& oracle_;
  std::deque<node_added_t> nodes_;
  std::deque<register_request_t> requests_;
  int64_t known_keyframe_ = -1;
  int64_t messages_ = 0;
  int64_t decode_errors_ = 0;
  int64_t false_matches_ = 0;
  std::function<void()> after_update_;
};

// Ground truth at `utime`: linear in position between the samples around it, rotation of
// the nearer one (samples are 0.1 s apart; the rotation error of that is below the metric's
// interest here).
core::SE3d truthAt(const std::map<int64_t, core::SE3d>& gt, int64_t utime) {
  auto hi = gt.lower_bound(utime);
  if (hi == gt.end()) return std::prev(hi)->second;
  if (hi->first == utime || hi == gt.begin()) return hi->second;
  auto lo = std::prev(hi);
  const double a = static_cast<double>(utime - lo->first) / static_cast<double>(hi->first - lo->first);
  const core::Vec3 t = (1 - a) * lo->second.translation() + a * hi->second.translation();
  return core::SE3d(a < 0.5 ? lo->second.so3() : hi->second.so3(), t);
}

}  // namespace

std::string OfflineRunSummary::text() const {
  std::ostringstream s;
  s << stats.text() << "nodes_by_session";
  for (int64_t n : nodes_by_session) s << " " << n;
  s << "\nmessages " << messages << "\ndecode_errors " << decode_errors
    << "\nfalse_matches " << false_matches << "\nsimulated_s " << duration_s << "\ndistance_m "
    << distance_m << "\nstep_poses " << step_poses << "\nate_rmse_m " << ate_rmse_m
    << "\nate_median_m " << ate_median_m << "\ntime_tracking_s " << stats.timing.tracking_s
    << "\ntime_registration_s " << stats.timing.registration_s << "\ntime_partition_s "
    << stats.timing.partition_s << "\ntime_solver_s " << stats.timing.solver_s
    << "\nupdate_median_ms " << update_median_ms << "\nupdate_p99_ms " << update_p99_ms << "\nstore_transactions " << store_transactions
    << "\ntime_store_s " << store_s << "\n";
  return s.str();
}

Expected<OfflineRunSummary> runOffline(const sim::SimOptions& sim_options, MapperOptions options,
                                       const std::filesystem::path& store_file) {
  if (Status s = options.validate(); !s) return s.error();
  auto plan = sim::RunPlan::create(sim_options);
  if (!plan) return plan.error();
  options.tracker.body_T_cam = sim_options.sensors.camera.bodyTCam();
  Mapper mapper(options);
  sim::RegistrationOracle oracle(sim_options.oracle, plan->oracleSeed());
  Broker broker(mapper, oracle);
  std::map<int64_t, core::SE3d> truth;
  std::optional<MapStore> store;
  int64_t stored_nodes = 0, stored_constraints = 0, transactions = 0;
  double store_s = 0.0;
  Status store_status = Ok{};
  if (!store_file.empty()) {
    auto s = MapStore::open(store_file);
    if (!s) return s.error();
    store = std::move(*s);
    broker.setAfterUpdate([&] {
      const MapperStats& st = mapper.stats();
      if (!store_status || (st.nodes == stored_nodes && st.constraints == stored_constraints)) return;
      const auto t0 = std::chrono::steady_clock::now();
      store_status = store->save(mapper, 0, 0);
      store_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      stored_nodes = st.nodes;
      stored_constraints = st.constraints;
      ++transactions;
    });
  }
  sim::SessionObservers observers;
  observers.on_keyframe = [&](const sim::KeyframeTruth& k) {
    oracle.addKeyframe(k);
    broker.keyframeKnown(k.utime);
  };
  observers.on_ground_truth = [&](int64_t utime, const sim::BodyState& b) { truth[utime] = b.world_T_body; };
  const sim::RunSummary run = sim::generateRun(*plan, [&](int) -> sim::MessageSink& { return broker; }, observers);

  if (!store_status) return store_status.error();
  OfflineRunSummary out;
  out.store_transactions = transactions;
  out.store_s = store_s;
  out.stats = mapper.stats();
  out.nodes = static_cast<int64_t>(mapper.nodes().size());
  for (const MapperNode& n : mapper.nodes()) {
    if (n.session >= static_cast<int>(out.nodes_by_session.size())) out.nodes_by_session.resize(n.session + 1, 0);
    ++out.nodes_by_session[n.session];
  }
  out.factors = mapper.stats().factors;
  out.constraints = static_cast<int64_t>(mapper.constraints().all().size());
  out.messages = broker.messages();
  out.decode_errors = broker.decodeErrors();
  out.false_matches = broker.falseMatches();
  out.duration_s = run.durationS();
  out.distance_m = run.distanceM();
  std::vector<double> ms;
  for (double s : mapper.stats().timing.update_s) ms.push_back(1e3 * s);
  out.update_median_ms = percentile(ms, 0.5);
  out.update_p99_ms = percentile(ms, 0.99);

  std::vector<core::SE3d> gt, est;
  for (const auto& p : mapper.stepPoses()) {
    if (truth.empty()) break;
    gt.push_back(truthAt(truth, p.utime));
    est.push_back(mapper.nodePose(p.node) * p.node_T_body);
  }
  out.step_poses = static_cast<int64_t>(est.size());
  auto aligned = eval::alignTrajectories(gt, est, eval::AlignmentMode::kSE3);
  if (!aligned) return makeError("offline run: ATE: ", aligned.error().message);
  for (auto& e : est) e = aligned->gt_S_est * e;
  auto ate = eval::computeAte(gt, est);
  if (!ate) return makeError("offline run: ATE: ", ate.error().message);
  out.ate_rmse_m = ate->translation_m.rmse;
  out.ate_median_m = ate->translation_m.median;
  return out;
}

}  // namespace evermap::mapper
