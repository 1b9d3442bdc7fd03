#include "core/sim/oracle_server.h"

#include <cstdio>

#include "core/messages/channels.h"

namespace evermap::sim {

OracleServer::OracleServer(lcm::LCM& lcm, RegistrationOracle& oracle) : lcm_(lcm), oracle_(oracle) {
  lcm_.subscribe(channels::kNodeAdded, &OracleServer::onNodeAdded, this);
  lcm_.subscribe(channels::kRegisterRequest, &OracleServer::onRequest, this);
}

void OracleServer::onNodeAdded(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  node_added_t m;
  if (m.decode(buffer->data, 0, static_cast<int>(buffer->data_size)) < 0 || m.keyframe_utime <= 0) {
    ++dropped_;
    std::fprintf(stderr, "evermap::sim oracle: dropped a malformed %s message\n", channel.c_str());
    return;
  }
  if (!oracle_.addNode(m)) {
    std::fprintf(stderr, "evermap::sim oracle: node %lld names unknown keyframe %lld\n",
                 static_cast<long long>(m.node_id), static_cast<long long>(m.keyframe_utime));
  }
}

void OracleServer::onRequest(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  register_request_t m;
  if (m.decode(buffer->data, 0, static_cast<int>(buffer->data_size)) < 0) {
    ++dropped_;
    std::fprintf(stderr, "evermap::sim oracle: dropped a malformed %s message\n", channel.c_str());
    return;
  }
  // The oracle answers malformed requests itself (STATUS_MALFORMED), so the mapper hears back.
  const register_result_t r = oracle_.answer(m);
  lcm_.publish(channels::kRegisterResult, &r);
  ++answered_;
}

}  // namespace evermap::sim
