#pragma once
// The mapper's map store (DESIGN.md section 7): the map written to its file (the schema is
// core/map/store_file.h's, the reader core/map/store_reader.h's), one transaction per update
// (then a checkpoint that empties the log), so a process killed at any moment leaves the last
// committed map loadable.
//
// The tracking state (Mapper::trackingState: the node tracked against, Δ, floor, session,
// message time) is written in every save's transaction with the map it refers to, and on its
// own by saveTracking() between them; no row while the mapper is lost. A restarted mapper
// resumes from it (MapperOptions::warm_restart_max_gap_s).
//
// Every constraint is an edge (accepted or rejected, DESIGN.md section 3) until its pair is
// folded; node poses are the latest estimates, rewritten in an update's transaction when they
// moved.
//
// Folding (paper section I: the graph, and so the store, grows with the area, not with the
// time): once a pair of nodes holds `fold_after` rows, the transaction that adds the last one
// replaces them by one row, the pair's merged estimate (ConstraintSet::Pair::i_T_j, the
// information-weighted fusion of its accepted constraints), with a map_folds row saying how
// many accepted and rejected constraints it stands for and since when. The row keeps the id
// of the pair's oldest row, and so its place in the file: folds rewrite a pair's row in place,
// and a map visited again and again keeps its size. A restored mapper adds
// it as the pair's first constraint, so the pair's factor and the gate for its next
// constraints are what they were. A fold is undone as a whole: deleting its row removes the
// pair's evidence (the next visit registers the pair anew); the single constraints folded
// into it are not kept.

#include <cstdint>
#include <filesystem>
#include <set>
#include <utility>
#include <vector>

#include "core/common/expected.h"
#include "core/map/store_file.h"
#include "core/map/store_reader.h"
#include "mapper-proc/constraint_set.h"
#include "mapper-proc/map_node.h"

namespace evermap::mapper {

class Mapper;

struct MapStoreOptions {
  // A pair's rows are folded into one when they reach this many (0: never fold). 2: a pair's
  // second constraint, accepted by the gate, agrees with the first and is folded with it.
  int fold_after = 2;
  // Open an existing store to read it only (a tool; the viewer reads through core/map): no file is
  // created, the schema is not touched and save() refuses.
  bool read_only = false;
};

class MapStore {
 public:
  // Opens (creating if needed) the file, switches it to WAL and creates the tables. Errors
  // name the file.
  static Expected<MapStore> open(const std::filesystem::path& file,
                                 const MapStoreOptions& options = {});

  // One transaction: the session row, the floors, every node new or moved since the last save
  // (inserted or its pose updated),
  // the constraints of this mapper not stored yet (map_saved), and the folds they
  // complete.
  // And the mapper's tracking state (map_tracking), in the same transaction.
  Status save(const Mapper& mapper, int session, int64_t session_start_utime);
  // The tracking state alone, one small transaction (between saves: the robot moves on
  // between graph updates). Refused when the state names a node this store does not hold.
  Status saveTracking(const Mapper& mapper);
  Expected<MapSnapshot> load() const { return map::readMap(file_); }
  // Rows of map_edges (a fold is one).
  Expected<int64_t> edgeRows() const { return file_.edgeRows(); }
  // PRAGMA user_version: the schema's version (core/map/store_file.h).
  Expected<int64_t> schemaVersion() const { return file_.schemaVersion(); }
  // PRAGMA integrity_check == "ok".
  Status integrityCheck() const { return file_.integrityCheck(); }

 private:
  // A node's pose blob as a save wrote it, by node id.
  using PoseRows = std::vector<std::pair<size_t, std::vector<double>>>;
  using NodePairs = std::set<std::pair<int64_t, int64_t>>;

  MapStore(map::StoreFile file, const MapStoreOptions& options, int64_t last_edge_id)
      : file_(std::move(file)), options_(options), last_edge_id_(last_edge_id) {}

  // save()'s transaction, in this order; each adds its rows or returns the error.
  Status writeUpdate(const Mapper& mapper, int session, int64_t session_start_utime,
                     PoseRows& written);
  Status writeSession(int session, int64_t session_start_utime);
  Status writeFloors(const Mapper& mapper);
  // The nodes new or moved since the last commit (and a new node's attitude): `written`.
  Status writeNodes(const Mapper& mapper, PoseRows& written);
  // The constraints of this session's mapper not stored yet; `touched` receives their pairs.
  Status writeConstraints(const Mapper& mapper, NodePairs& touched);
  // map_saved: how many of its constraints this session's mapper has stored.
  Status markSaved(const Mapper& mapper);
  // The footprints made since the last commit (map_footprints).
  Status writeFootprints(const Mapper& mapper);
  // Replaces map_tracking's row by the mapper's state (or deletes it), inside a transaction.
  Status writeTracking(const Mapper& mapper);

  // Folds the pair's rows into one when there are fold_after of them (inside save()).
  Status foldPair(const Mapper& mapper, int64_t i, int64_t j);
  // What a pair's rows stand for, and where its fold goes.
  struct PairRows {
    int64_t members = 0;  // accepted constraints (a fold counts its members)
    int64_t rejected = 0;
    int64_t first_utime = 0;
    int64_t last_utime = 0;
    int64_t oldest_id = 0;  // the pair's oldest row
    int64_t kind = 0;       // its first constraint's
  };
  Expected<PairRows> pairRows(int64_t i, int64_t j) const;
  Status deletePairRows(int64_t i, int64_t j);
  Status insertFold(int64_t i, int64_t j, const PairRows& rows, const core::UncertainPose& merged);

  map::StoreFile file_;
  MapStoreOptions options_;
  int64_t last_edge_id_ = -1;  // highest edge id in the file
  // Each node's pose as this object last committed it (poseBlob), by id: save() writes the
  // rows that changed.
  std::vector<std::vector<double>> stored_poses_;
  size_t stored_footprints_ = 0;  // the mapper's footprints this object has committed
};

}  // namespace evermap::mapper
