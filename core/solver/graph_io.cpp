#include "core/solver/graph_io.h"

#include <cerrno>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "core/common/enum_names.h"
#include "core/solver/factor.h"

namespace evermap::solver {
namespace {

// Splits on whitespace; numbers parsed with strtod so that "nan"/"inf" are caught later.
std::vector<std::string> tokens(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream in(line);
  std::string t;
  while (in >> t) out.push_back(t);
  return out;
}

bool toDouble(const std::string& s, double* v) {
  char* end = nullptr;
  errno = 0;
  *v = std::strtod(s.c_str(), &end);
  return end && *end == '\0' && end != s.c_str();
}

bool toKey(const std::string& s, Key* k) {
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (!end || *end != '\0' || end == s.c_str() || errno == ERANGE) return false;
  *k = v;
  return true;
}

struct LineParser {
  const std::string& where;  // "file:line"
  const std::vector<std::string>& t;

  // Checks the count of fields after the tag, accepting any of `counts`.
  Status expectFields(std::initializer_list<size_t> counts) const {
    for (size_t c : counts) {
      if (t.size() == c + 1) return Ok{};
    }
    std::string want;
    for (size_t c : counts) want += (want.empty() ? "" : " or ") + std::to_string(c);
    return makeError(where, ": ", t[0], " expects ", want, " fields, got ", t.size() - 1);
  }
  Status keyAt(size_t i, Key* k) const {
    if (!toKey(t[i], k))
      return makeError(where, ": field ", i, " ('", t[i], "') is not an integer id");
    return Ok{};
  }
  Status numbers(size_t first, size_t count, double* out) const {
    for (size_t i = 0; i < count; ++i) {
      if (!toDouble(t[first + i], &out[i])) {
        return makeError(where, ": field ", first + i, " ('", t[first + i], "') is not a number");
      }
      if (!std::isfinite(out[i])) {
        return makeError(where, ": field ", first + i, " is not finite (", t[first + i], ")");
      }
    }
    return Ok{};
  }
};

// Upper-triangular n×n from n(n+1)/2 row-major entries.
Eigen::MatrixXd upperFromRowMajor(const double* v, int n, bool symmetric) {
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n, n);
  int k = 0;
  for (int r = 0; r < n; ++r) {
    for (int c = r; c < n; ++c) {
      M(r, c) = v[k++];
      if (symmetric) M(c, r) = M(r, c);
    }
  }
  return M;
}

GraphFormat sniff(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  bool saw_edge2_or_3 = false;
  while (std::getline(in, line)) {
    const auto t = tokens(line);
    if (t.empty() || t[0][0] == '#') continue;
    const std::string& tag = t[0];
    if (tag.rfind("VERTEX_SE", 0) == 0 || tag.rfind("EDGE_SE", 0) == 0 || tag == "VERTEX_XY" ||
        tag == "VERTEX_TRACKXYZ" || tag == "PARAMS_SE3OFFSET") {
      return GraphFormat::kG2o;
    }
    if (tag == "LANDMARK" || tag == "POINT3") return GraphFormat::kIsam;
    if (tag == "VERTEX2" || tag == "VERTEX3") return GraphFormat::kToro;
    if (tag == "ODOMETRY") return GraphFormat::kIsam;
    if (tag == "EDGE2" || tag == "EDGE3") saw_edge2_or_3 = true;
  }
  if (path.extension() == ".graph") return GraphFormat::kToro;
  return saw_edge2_or_3 ? GraphFormat::kIsam : GraphFormat::kG2o;
}

// An information matrix from a file: its square root when positive definite, else (when
// finite and symmetric) kept as read for resolveIndefiniteInformation.
Status setInformation(const Eigen::MatrixXd& I, const std::string& where, GraphEdge* e) {
  auto W = sqrtInformationFromInformation(I, where);
  if (W.ok()) {
    e->sqrt_information = *W;
    return Ok{};
  }
  const double scale = I.allFinite() ? I.cwiseAbs().maxCoeff() : 0.0;
  if (!I.allFinite() || (I - I.transpose()).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + scale)) {
    return W.error();
  }
  e->indefinite_information = 0.5 * (I + I.transpose());
  return Ok{};
}

double smallestEigenvalue(const Eigen::MatrixXd& I) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(I, Eigen::EigenvaluesOnly)
      .eigenvalues()
      .minCoeff();
}

Status addVertex(GraphFile* g, const GraphVertex& v, std::map<Key, int>* seen,
                 const std::string& where) {
  if (seen->count(v.id)) return makeError(where, ": vertex ", v.id, " defined twice");
  (*seen)[v.id] = static_cast<int>(g->vertices.size());
  g->vertices.push_back(v);
  return Ok{};
}

// The reading of one graph file, line by line: the graph read so far, and what the checks
// across lines need (the dimension, the vertex ids seen).
class GraphReader {
 public:
  GraphReader(const std::filesystem::path& path, GraphFormat format) {
    g_.path = path.string();
    g_.format = format == GraphFormat::kAuto ? sniff(path) : format;
  }

  // One line of the file, split into tokens (not empty, not a comment).
  Status readLine(int line_no, const std::vector<std::string>& t);
  // The checks that need the whole file; then the graph.
  Expected<GraphFile> finish();

 private:
  Status setDim(int d, const std::string& where);
  // VERTEX_SE2 (g2o), VERTEX2 (TORO): "TAG id x y θ".
  // A vertex line of a `dim`-D graph: its id into vx and its `n` numbers into v_.
  Status vertexFields(const LineParser& p, int dim, size_t n, GraphVertex* vx);
  Status planarVertex(const LineParser& p);
  Status spatialVertex(const LineParser& p);
  // An edge line of a `dim`-D graph with any of `fields` fields after the tag: its keys into
  // e and the numbers after them into v_.
  Status edgeFields(const LineParser& p, int dim, std::initializer_list<size_t> fields,
                    GraphEdge* e);
  // Every 2-D edge line is "TAG from to dx dy dθ" and six information numbers whose layout
  // depends on the format; `sqrt_info` turns those six into the square-root information.
  template <typename SqrtInfo>
  Status planarEdge(const LineParser& p, SqrtInfo sqrt_info, bool from_information);
  Status g2oSpatialEdge(const LineParser& p);
  Status isamSpatialEdge(const LineParser& p);
  Status fixedVertices(const LineParser& p);
  Status landmarkVertex(const LineParser& p);
  Status sensorOffset(const LineParser& p);
  Status observation(const LineParser& p);
  // g2o's "x y z qx qy qz qw" at v.
  Expected<core::SE3d> g2oPose(const double* v, const std::string& where) const;

  GraphFile g_;
  bool dim_known_ = false;
  std::map<Key, int> seen_;
  std::set<Key> landmark_vertices_;
  int line_no_ = 0;
  double v_[40];
};

#define EVERMAP_TRY(expr)           \
  if (auto s_ = (expr); !s_.ok()) { \
    return s_.error();              \
  }

Status GraphReader::setDim(int d, const std::string& where) {
  if (dim_known_ && g_.dimension != d) {
    return makeError(where, ": mixes 2-D and 3-D poses");
  }
  g_.dimension = d;
  dim_known_ = true;
  return Ok{};
}

Expected<core::SE3d> GraphReader::g2oPose(const double* v, const std::string& where) const {
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (q.norm() < 1e-6) return makeError(where, ": quaternion has zero norm");
  return core::SE3d(q, core::Vec3(v[0], v[1], v[2]));
}

Status GraphReader::vertexFields(const LineParser& p, int dim, size_t n, GraphVertex* vx) {
  EVERMAP_TRY(setDim(dim, p.where));
  EVERMAP_TRY(p.expectFields({1 + n}));
  EVERMAP_TRY(p.keyAt(1, &vx->id));
  return p.numbers(2, n, v_);
}

Status GraphReader::planarVertex(const LineParser& p) {
  GraphVertex vx;
  EVERMAP_TRY(vertexFields(p, 2, 3, &vx));
  vx.pose = PoseValue::planar(core::SE2d(v_[0], v_[1], v_[2]));
  return addVertex(&g_, vx, &seen_, p.where);
}

Status GraphReader::spatialVertex(const LineParser& p) {
  GraphVertex vx;
  EVERMAP_TRY(vertexFields(p, 3, 7, &vx));
  const Expected<core::SE3d> pose = g2oPose(v_, p.where);
  if (!pose) return pose.error();
  vx.pose = PoseValue::spatial(*pose);
  return addVertex(&g_, vx, &seen_, p.where);
}

Status GraphReader::edgeFields(const LineParser& p, int dim, std::initializer_list<size_t> fields,
                               GraphEdge* e) {
  EVERMAP_TRY(setDim(dim, p.where));
  EVERMAP_TRY(p.expectFields(fields));
  EVERMAP_TRY(p.keyAt(1, &e->from));
  EVERMAP_TRY(p.keyAt(2, &e->to));
  return p.numbers(3, p.t.size() - 3, v_);
}

template <typename SqrtInfo>
Status GraphReader::planarEdge(const LineParser& p, SqrtInfo sqrt_info, bool from_information) {
  GraphEdge e;
  EVERMAP_TRY(edgeFields(p, 2, {11}, &e));
  e.measurement = PoseValue::planar(core::SE2d(v_[0], v_[1], v_[2]));
  auto W = sqrt_info(v_ + 3);
  if (!W.ok()) return W.error();
  if (from_information) {
    EVERMAP_TRY(setInformation(*W, p.where, &e));
  } else {
    e.sqrt_information = *W;
  }
  e.line = line_no_;
  g_.edges.push_back(std::move(e));
  return Ok{};
}

Status GraphReader::g2oSpatialEdge(const LineParser& p) {
  GraphEdge e;
  EVERMAP_TRY(edgeFields(p, 3, {30}, &e));
  const Expected<core::SE3d> z = g2oPose(v_, p.where);
  if (!z) return z.error();
  e.measurement = PoseValue::spatial(*z);
  EVERMAP_TRY(setInformation(upperFromRowMajor(v_ + 7, 6, true), p.where, &e));
  e.line = line_no_;
  g_.edges.push_back(std::move(e));
  return Ok{};
}

Status GraphReader::isamSpatialEdge(const LineParser& p) {
  const std::vector<std::string>& t = p.t;
  GraphEdge e;
  EVERMAP_TRY(edgeFields(p, 3, {8, 29}, &e));
  // File angles: roll, pitch, yaw (iSAM Loader); R = Rz(yaw) Ry(pitch) Rx(roll).
  core::SE3d z(core::SO3d::fromRollPitchYaw(v_[3], v_[4], v_[5]), core::Vec3(v_[0], v_[1], v_[2]));
  Eigen::MatrixXd S = Eigen::MatrixXd::Identity(6, 6);
  if (t.size() == 30) {
    const double* s = v_ + 6;  // s11 s12 ... s16 s22 ... s66
    S = upperFromRowMajor(s, 6, false);
    // Rotation rows in (yaw, pitch, roll) order, as iSAM's Loader builds them.
    const double s44 = S(3, 3), s45 = S(3, 4), s46 = S(3, 5);
    const double s55 = S(4, 4), s56 = S(4, 5), s66 = S(5, 5);
    S(3, 3) = s66;
    S(3, 4) = s56;
    S(3, 5) = s46;
    S(4, 4) = s55;
    S(4, 5) = s45;
    S(5, 5) = s44;
  }
  auto W = checkSqrtInformation(S, p.where);
  if (!W.ok()) return W.error();
  if (e.from > e.to) {
    // iSAM keeps the square root and inverts the measurement (Loader::parse_line).
    std::swap(e.from, e.to);
    z = z.inverse();
  }
  e.measurement = PoseValue::spatial(z);
  e.sqrt_information = *W;
  e.line = line_no_;
  g_.edges.push_back(std::move(e));
  return Ok{};
}

Status GraphReader::fixedVertices(const LineParser& p) {
  for (size_t i = 1; i < p.t.size(); ++i) {
    Key k;
    EVERMAP_TRY(p.keyAt(i, &k));
    g_.fixed.push_back(k);
  }
  return Ok{};
}

Status GraphReader::landmarkVertex(const LineParser& p) {
  const int d = p.t[0] == "VERTEX_XY" ? 2 : 3;
  GraphLandmark l;
  EVERMAP_TRY(setDim(d, p.where));
  EVERMAP_TRY(p.expectFields({static_cast<size_t>(d + 1)}));
  EVERMAP_TRY(p.keyAt(1, &l.id));
  EVERMAP_TRY(p.numbers(2, d, v_));
  if (seen_.count(l.id) || !landmark_vertices_.insert(l.id).second) {
    return makeError(p.where, ": vertex ", l.id, " defined twice");
  }
  l.position = d == 2 ? PoseValue::point2(core::Vec2(v_[0], v_[1]))
                      : PoseValue::point3(core::Vec3(v_[0], v_[1], v_[2]));
  g_.landmarks.push_back(l);
  return Ok{};
}

Status GraphReader::sensorOffset(const LineParser& p) {
  Key id;
  EVERMAP_TRY(p.expectFields({8}));
  EVERMAP_TRY(p.keyAt(1, &id));
  EVERMAP_TRY(p.numbers(2, 7, v_));
  const Expected<core::SE3d> offset = g2oPose(v_, p.where);
  if (!offset) return offset.error();
  g_.sensor_offsets[static_cast<int>(id)] = *offset;
  return Ok{};
}

// EDGE_SE2_XY, EDGE_SE3_TRACKXYZ (g2o); LANDMARK, POINT3 (iSAM).
Status GraphReader::observation(const LineParser& p) {
  const std::vector<std::string>& t = p.t;
  const std::string& tag = t[0];
  const bool isam = g_.format == GraphFormat::kIsam;
  const int d = (tag == "EDGE_SE2_XY" || tag == "LANDMARK") ? 2 : 3;
  const size_t tri = d == 2 ? 3 : 6;  // upper-triangle entries
  const size_t param = tag == "EDGE_SE3_TRACKXYZ" ? 1 : 0;
  GraphObservation o;
  EVERMAP_TRY(setDim(d, p.where));
  if (tag == "POINT3") {
    EVERMAP_TRY(p.expectFields({5, 11}));
  } else {
    EVERMAP_TRY(p.expectFields({2 + param + d + tri}));
  }
  EVERMAP_TRY(p.keyAt(1, &o.pose));
  EVERMAP_TRY(p.keyAt(2, &o.landmark));
  if (isam) o.landmark = isamLandmarkKey(o.landmark);
  if (param) {
    Key id;
    EVERMAP_TRY(p.keyAt(3, &id));
    const auto it = g_.sensor_offsets.find(static_cast<int>(id));
    if (it == g_.sensor_offsets.end()) {
      return makeError(p.where, ": ", tag, " uses parameter ", id,
                       " without a PARAMS_SE3OFFSET line before it");
    }
    o.offset_param = static_cast<int>(id);
    o.pose_T_sensor = it->second;
  }
  const size_t first = 3 + param;
  EVERMAP_TRY(p.numbers(first, t.size() - first, v_));
  for (int k = 0; k < d; ++k) o.measured[k] = v_[k];
  if (t.size() - first == static_cast<size_t>(d)) {
    o.sqrt_information = Eigen::MatrixXd::Identity(d, d);  // iSAM's POINT3 without numbers
  } else if (isam) {
    auto W = checkSqrtInformation(upperFromRowMajor(v_ + d, d, false), p.where);
    if (!W.ok()) return W.error();
    o.sqrt_information = *W;
  } else {
    auto W = sqrtInformationFromInformation(upperFromRowMajor(v_ + d, d, true), p.where);
    if (!W.ok()) return W.error();
    o.sqrt_information = *W;
  }
  o.line = line_no_;
  o.edges_before = static_cast<int>(g_.edges.size());
  g_.observations.push_back(std::move(o));
  return Ok{};
}

Status GraphReader::readLine(int line_no, const std::vector<std::string>& t) {
  line_no_ = line_no;
  const std::string where = g_.path + ":" + std::to_string(line_no);
  const LineParser p{where, t};
  const std::string& tag = t[0];
  const bool g2o = g_.format == GraphFormat::kG2o;
  const bool toro = g_.format == GraphFormat::kToro;
  const bool isam = g_.format == GraphFormat::kIsam;
  if ((g2o && tag == "VERTEX_SE2") || (toro && tag == "VERTEX2")) return planarVertex(p);
  if (g2o && tag == "VERTEX_SE3:QUAT") return spatialVertex(p);
  if (g2o && tag == "EDGE_SE2") {
    return planarEdge(
        p,
        [&](const double* info) -> Expected<Eigen::MatrixXd> {
          return upperFromRowMajor(info, 3, true);
        },
        true);
  }
  if (g2o && tag == "EDGE_SE3:QUAT") return g2oSpatialEdge(p);
  if (g2o && tag == "FIX") return fixedVertices(p);
  if (toro && tag == "EDGE2") {
    return planarEdge(
        p,
        [&](const double* info) -> Expected<Eigen::MatrixXd> {
          // TORO: Ixx Ixy Iyy Iθθ Ixθ Iyθ.
          Eigen::MatrixXd I(3, 3);
          I << info[0], info[1], info[4], info[1], info[2], info[5], info[4], info[5], info[3];
          return I;
        },
        true);
  }
  if (isam && (tag == "ODOMETRY" || tag == "EDGE2")) {
    return planarEdge(
        p,
        [&](const double* sqrt_info) {
          return checkSqrtInformation(upperFromRowMajor(sqrt_info, 3, false), where);
        },
        false);
  }
  if (isam && tag == "EDGE3") return isamSpatialEdge(p);
  if (g2o && (tag == "VERTEX_XY" || tag == "VERTEX_TRACKXYZ")) return landmarkVertex(p);
  if (g2o && tag == "PARAMS_SE3OFFSET") return sensorOffset(p);
  if ((g2o && (tag == "EDGE_SE2_XY" || tag == "EDGE_SE3_TRACKXYZ")) ||
      (isam && (tag == "LANDMARK" || tag == "POINT3"))) {
    return observation(p);
  }
  ++g_.skipped_tags[tag];
  return Ok{};
}

#undef EVERMAP_TRY

Expected<GraphFile> GraphReader::finish() {
  for (Key id : landmark_vertices_) {
    if (seen_.count(id))
      return makeError(g_.path, ": vertex ", id, " is both a pose and a landmark");
  }
  if (g_.format == GraphFormat::kIsam && !g_.observations.empty()) {
    for (const GraphEdge& e : g_.edges) {
      if (std::max(e.from, e.to) >= kIsamLandmarkKeyBase) {
        return makeError(g_.path, ":", e.line, ": pose id ", std::max(e.from, e.to),
                         " collides with the landmark keys (from ", kIsamLandmarkKeyBase, ")");
      }
    }
  }
  return std::move(g_);
}

}  // namespace

const char* graphFormatName(GraphFormat f) {
  static constexpr EnumNames<GraphFormat, 4> kNames{{
      {GraphFormat::kAuto, "auto"},
      {GraphFormat::kG2o, "g2o"},
      {GraphFormat::kToro, "toro"},
      {GraphFormat::kIsam, "isam"},
  }};
  return nameOf(kNames, f);
}

Expected<IndefiniteInformation> parseIndefiniteInformation(const std::string& text) {
  if (text == "refuse") return IndefiniteInformation::kRefuse;
  if (text == "blocks") return IndefiniteInformation::kBlocks;
  if (text == "nearest" || text == "nearest-pd") return IndefiniteInformation::kNearest;
  return makeError("indefinite information rule '", text, "': expected refuse, blocks or nearest");
}

Eigen::MatrixXd nearestPositiveDefinite(const Eigen::MatrixXd& information, double relative_floor) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(information);
  Eigen::VectorXd lambda = eig.eigenvalues();
  const double floor = relative_floor * lambda.maxCoeff();
  for (int i = 0; i < lambda.size(); ++i) lambda[i] = std::max(lambda[i], floor);
  const Eigen::MatrixXd& V = eig.eigenvectors();
  const Eigen::MatrixXd out = V * lambda.asDiagonal() * V.transpose();
  return 0.5 * (out + out.transpose());
}

Expected<int> resolveIndefiniteInformation(GraphFile* g, IndefiniteInformation rule) {
  int changed = 0;
  const int d = g->dimension;
  for (GraphEdge& e : g->edges) {
    if (e.positiveDefinite()) continue;
    const Eigen::MatrixXd& I = e.indefinite_information;
    const std::string where = g->path + ":" + std::to_string(e.line) + ": edge " +
                              std::to_string(e.from) + "-" + std::to_string(e.to);
    Eigen::MatrixXd repaired;
    switch (rule) {
      case IndefiniteInformation::kRefuse:
        return makeError(where,
                         ": information matrix is not positive definite (smallest "
                         "eigenvalue ",
                         smallestEigenvalue(I),
                         "); --indefinite-information "
                         "blocks|nearest repairs it, --objective sesync uses only its blocks");
      case IndefiniteInformation::kBlocks: {
        const int nt = d;             // translation rows
        const int nr = I.rows() - d;  // rotation rows
        repaired = Eigen::MatrixXd::Zero(I.rows(), I.cols());
        repaired.topLeftCorner(nt, nt) = I.topLeftCorner(nt, nt);
        repaired.bottomRightCorner(nr, nr) = I.bottomRightCorner(nr, nr);
        break;
      }
      case IndefiniteInformation::kNearest:
        if (!(I.diagonal().maxCoeff() > 0.0)) {
          return makeError(where, ": information matrix has no positive eigenvalue");
        }
        repaired = nearestPositiveDefinite(I);
        break;
    }
    auto W = sqrtInformationFromInformation(repaired, where);
    if (!W.ok()) return W.error();
    e.sqrt_information = *W;
    e.indefinite_information.resize(0, 0);
    ++changed;
  }
  return changed;
}

int GraphFile::numLandmarks() const {
  std::set<Key> ids;
  for (const GraphLandmark& l : landmarks) ids.insert(l.id);
  for (const GraphObservation& o : observations) ids.insert(o.landmark);
  return static_cast<int>(ids.size());
}

int GraphFile::skippedLines() const {
  int n = 0;
  for (const auto& [tag, count] : skipped_tags) n += count;
  return n;
}

Expected<GraphFile> readGraphFile(const std::filesystem::path& path, GraphFormat format) {
  std::ifstream in(path);
  if (!in) return makeError(path.string(), ": cannot open");
  GraphReader reader(path, format);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto t = tokens(line);
    if (t.empty() || t[0][0] == '#') continue;
    if (Status s = reader.readLine(line_no, t); !s.ok()) return s.error();
  }
  if (in.bad()) return makeError(path.string(), ": read error");
  return reader.finish();
}

}  // namespace evermap::solver
