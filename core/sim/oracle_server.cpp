#include "core/sim/oracle_server.h"

#include <cstdio>

#include "core/messages/channels.h"
#include "core/messages/convert.h"

namespace evermap::sim {

OracleServer::OracleServer(lcm::LCM& lcm, RegistrationOracle& oracle) : lcm_(lcm), oracle_(oracle) {
  lcm_.subscribe(channels::kNodeAdded, &OracleServer::onNodeAdded, this);
  lcm_.subscribe(channels::kRegisterRequest, &OracleServer::onRequest, this);
}

void OracleServer::onNodeAdded(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  auto m = messages::decodeLcm<node_added_t>(buffer->data, buffer->data_size, channel);
  if (!m) {
    ++dropped_;
    std::fprintf(stderr, "evermap::sim oracle: dropped: %s\n", m.error().message.c_str());
    return;
  }
  if (!oracle_.addNode(*m)) {
    std::fprintf(stderr, "evermap::sim oracle: node %lld names unknown keyframe %lld\n",
                 static_cast<long long>(m->node_id), static_cast<long long>(m->keyframe_utime));
  }
}

void OracleServer::onRequest(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  auto m = messages::decodeLcm<register_request_t>(buffer->data, buffer->data_size, channel);
  if (!m) {
    ++dropped_;
    std::fprintf(stderr, "evermap::sim oracle: dropped: %s\n", m.error().message.c_str());
    return;
  }
  // The oracle answers invalid requests itself (STATUS_MALFORMED), so the mapper hears back.
  const register_result_t r = oracle_.answer(*m);
  lcm_.publish(channels::kRegisterResult, &r);
  ++answered_;
}

}  // namespace evermap::sim
