#include "tools/sim/oracle_server.h"

#include <sqlite3.h>

#include <cstdio>
#include <optional>
#include <utility>

#include "core/messages/channels.h"
#include "core/messages/convert.h"

namespace evermap::sim {

Expected<int64_t> loadStoredNodes(RegistrationOracle& oracle, const std::filesystem::path& store) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(store.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    const std::string why = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    return makeError(store.string(), ": cannot open map store (", why, ")");
  }
  sqlite3_busy_timeout(db, 5000);  // the mapper may be committing
  sqlite3_stmt* st = nullptr;
  const char* sql =
      "SELECT node_id, keyframe_utime, floor, session_id FROM map_nodes ORDER BY node_id";
  if (sqlite3_prepare_v2(db, sql, -1, &st, nullptr) != SQLITE_OK) {
    const std::string why = sqlite3_errmsg(db);
    sqlite3_close(db);
    if (why.find("no such table") != std::string::npos) return int64_t{0};
    return makeError(store.string(), ": not a map store (", why, ")");
  }
  int64_t told = 0;
  int rc = SQLITE_ROW;
  while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
    node_added_t n{};
    n.node_id = sqlite3_column_int64(st, 0);
    n.keyframe_utime = sqlite3_column_int64(st, 1);
    n.utime = n.keyframe_utime;
    n.floor = sqlite3_column_int(st, 2);
    n.session = sqlite3_column_int(st, 3);
    told += oracle.addNode(n) ? 1 : 0;
  }
  const std::string why = sqlite3_errmsg(db);
  sqlite3_finalize(st);
  sqlite3_close(db);
  if (rc != SQLITE_DONE) return makeError(store.string(), ": reading map_nodes: ", why);
  return told;
}

OracleServer::OracleServer(lcm::LCM& lcm, RegistrationOracle& oracle, messages::Signer signer)
    : lcm_(lcm), out_(lcm, std::move(signer)), oracle_(oracle) {
  // A node or a request lost to a full queue is an answer the mapper never gets.
  lcm_.subscribe(channels::kNodeAdded, &OracleServer::onNodeAdded, this)->setQueueCapacity(0);
  lcm_.subscribe(channels::kRegisterRequest, &OracleServer::onRequest, this)->setQueueCapacity(0);
}

template <typename Msg>
std::optional<Msg> OracleServer::decode(const lcm::ReceiveBuffer* buffer,
                                        const std::string& channel) {
  auto m = messages::decodeLcm<Msg>(
      buffer->data, messages::messageSize(buffer->data, buffer->data_size), channel);
  if (m) return std::move(*m);
  ++dropped_;
  std::fprintf(stderr, "evermap::sim oracle: dropped: %s\n", m.error().message.c_str());
  return std::nullopt;
}

void OracleServer::onNodeAdded(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  const auto m = decode<node_added_t>(buffer, channel);
  if (!m) return;
  if (!oracle_.addNode(*m)) {
    std::fprintf(stderr, "evermap::sim oracle: node %lld names unknown keyframe %lld\n",
                 static_cast<long long>(m->node_id), static_cast<long long>(m->keyframe_utime));
  }
}

void OracleServer::onRequest(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  const auto m = decode<register_request_t>(buffer, channel);
  if (!m) return;
  // The oracle answers invalid requests itself (STATUS_MALFORMED), so the mapper hears back.
  const register_result_t r = oracle_.answer(*m);
  out_.publish(channels::kRegisterResult, r);
  ++answered_;
}

}  // namespace evermap::sim
