// evermap-mapper-proc: the reduced pose graph mapper on LCM (DESIGN.md section 1). Parses
// options, wires LCM and runs the loop; the logic is Mapper. Publishes REGISTER_REQUEST,
// NODE_ADDED and POSE. Exit status: 0 on SIGINT/SIGTERM, 1 LCM failure, 2 bad command line.

#include <csignal>
#include <cstdio>
#include <ctime>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "core/sim/sensors.h"
#include "mapper-proc/mapper.h"

namespace {

using namespace evermap;

constexpr const char* kUsage =
    "usage: evermap-mapper-proc [--full-graph] [--lcm-url URL]\n"
    "  --full-graph   a node at every step (the paper's baseline) instead of the reduced graph\n"
    "  --lcm-url URL  LCM provider (default: LCM's default, $LCM_DEFAULT_URL)\n";

class Wiring {
 public:
  Wiring(lcm::LCM& lcm, mapper::Mapper& m) : lcm_(lcm), m_(m) {
    for (auto* s : {lcm_.subscribe(channels::kVoDelta, &Wiring::on<vo_delta_t>, this),
                    lcm_.subscribe(channels::kWheelOdom, &Wiring::on<wheel_odom_t>, this),
                    lcm_.subscribe(channels::kAttitude, &Wiring::on<attitude_t>, this),
                    lcm_.subscribe(channels::kFloor, &Wiring::on<floor_t>, this),
                    lcm_.subscribe(channels::kRegisterResult, &Wiring::on<register_result_t>, this)})
      s->setQueueCapacity(0);  // every odometry message counts (docs/lcm.md)
  }
  int64_t dropped() const { return dropped_; }

 private:
  template <typename Msg>
  void on(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    auto msg = messages::decodeLcm<Msg>(rbuf->data, rbuf->data_size, channel);
    if (!msg) {
      ++dropped_;
      std::fprintf(stderr, "evermap-mapper-proc: %s\n", msg.error().message.c_str());
      return;
    }
    Status s = apply(*msg);
    if (!s) std::fprintf(stderr, "evermap-mapper-proc: %s\n", s.error().message.c_str());
    for (const auto& r : m_.takeRequests()) lcm_.publish(channels::kRegisterRequest, &r);
    for (const auto& n : m_.takeNodesAdded()) lcm_.publish(channels::kNodeAdded, &n);
    if constexpr (std::is_same_v<Msg, vo_delta_t>) {
      if (m_.activeNode() >= 0) {
        const pose_t p = messages::toMsg(msg->utime, m_.pose(), m_.floor(), 0);
        lcm_.publish(channels::kPose, &p);
      }
    }
  }
  Status apply(const vo_delta_t& m) { return m_.onVo(m); }
  Status apply(const wheel_odom_t& m) { return m_.onWheel(m); }
  Status apply(const attitude_t& m) { return m_.onAttitude(m); }
  Status apply(const floor_t& m) { return m_.onFloor(m); }
  Status apply(const register_result_t& m) { return m_.onRegisterResult(m); }

  lcm::LCM& lcm_;
  mapper::Mapper& m_;
  int64_t dropped_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  mapper::MapperOptions options;
  options.tracker.body_T_cam = sim::CameraOptions{}.bodyTCam();
  std::string url;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (a == "--full-graph") {
      options.full_graph = true;
    } else if (a == "--lcm-url" && i + 1 < argc) {
      url = argv[++i];
    } else {
      std::fprintf(stderr, "evermap-mapper-proc: bad option %s\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  if (Status s = options.validate(); !s) {
    std::fprintf(stderr, "evermap-mapper-proc: %s\n", s.error().message.c_str());
    return 2;
  }
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-mapper-proc: cannot start LCM\n");
    return 1;
  }
  mapper::Mapper m(options);
  Wiring wiring(lcm, m);
  // SIGINT/SIGTERM are blocked and polled between LCM waits: no handler, no global flag.
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGINT);
  sigaddset(&stop, SIGTERM);
  sigprocmask(SIG_BLOCK, &stop, nullptr);
  const timespec no_wait{0, 0};
  while (sigtimedwait(&stop, nullptr, &no_wait) < 0) {
    if (lcm.handleTimeout(200) < 0) {
      std::fprintf(stderr, "evermap-mapper-proc: LCM failed\n");
      return 1;
    }
  }
  std::printf("mapper-proc: %s%lld undecodable messages\n", m.stats().text().c_str(),
              static_cast<long long>(wiring.dropped()));
  return 0;
}
