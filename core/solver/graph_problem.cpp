#include "core/solver/graph_problem.h"

#include <cmath>
#include <map>

#include <Eigen/Cholesky>

#include "core/solver/landmark_factors.h"
#include "core/solver/pose_factors.h"

namespace evermap::solver {

Expected<Objective> parseObjective(const std::string& text) {
  if (text == "native") return Objective::kNative;
  if (text == "sesync" || text == "chordal") return Objective::kSeSync;
  return makeError("objective '", text, "': expected native or sesync");
}

SeSyncWeights seSyncWeights(const GraphEdge& edge, int dimension) {
  const Eigen::MatrixXd I = edge.information();
  SeSyncWeights w;
  const int d = dimension;
  const Eigen::MatrixXd Itt = I.topLeftCorner(d, d);
  w.tau = d / Itt.inverse().trace();
  if (d == 2) {
    w.kappa = I(2, 2);
  } else {
    const Eigen::Matrix3d IRR = I.bottomRightCorner<3, 3>();
    w.kappa = 3.0 / (2.0 * IRR.inverse().trace());
  }
  return w;
}

Status checkInformation(const GraphFile& graph, Objective objective) {
  if (objective == Objective::kSeSync && !graph.observations.empty()) {
    return makeError(graph.path, ":", graph.observations.front().line,
                     ": SE-Sync's objective "
                     "has no landmark term; use --objective native for files with landmarks");
  }
  for (const GraphEdge& e : graph.edges) {
    const auto where = [&] {
      return graph.path + ":" + std::to_string(e.line) + ": edge " + std::to_string(e.from) + "-" +
             std::to_string(e.to);
    };
    if (objective == Objective::kNative) {
      if (!e.positiveDefinite()) {
        return makeError(where(),
                         ": information matrix is not positive definite; "
                         "--indefinite-information blocks|nearest repairs it, --objective "
                         "sesync uses only its translation and rotation blocks");
      }
      continue;
    }
    const Eigen::MatrixXd I = e.information();
    const int d = graph.dimension;
    const int nr = static_cast<int>(I.rows()) - d;
    const auto pd = [](const Eigen::MatrixXd& B) {
      return Eigen::LLT<Eigen::MatrixXd>(B).info() == Eigen::Success;
    };
    if (!pd(I.topLeftCorner(d, d)) || !pd(I.bottomRightCorner(nr, nr))) {
      return makeError(where(),
                       ": the translation or rotation block of the information "
                       "matrix is not positive definite (SE-Sync's weights need both)");
    }
  }
  return Ok{};
}

namespace {

// Adds SE-Sync's chordal cost of one edge a -> b measuring z (SE2d or SE3d) to *f:
// kappa |Rb - Ra Rz|^2, then tau |tb - ta - Ra tz|^2.
template <typename Pose>
void addChordalEdgeCost(const SeSyncWeights& w, const Pose& a, const Pose& b, const Pose& z,
                        double* f) {
  const auto Ra = a.rotationMatrix();
  const auto Rz = z.rotationMatrix();
  *f += w.kappa * (b.rotationMatrix() - Ra * Rz).squaredNorm();
  *f += w.tau * (b.translation() - a.translation() - Ra * z.translation()).squaredNorm();
}

}  // namespace

double seSyncCost(const GraphFile& graph, const Values& values) {
  double f = 0.0;
  for (const GraphEdge& e : graph.edges) {
    const SeSyncWeights w = seSyncWeights(e, graph.dimension);
    const PoseValue& a = values[e.from];
    const PoseValue& b = values[e.to];
    if (graph.dimension == 2) {
      addChordalEdgeCost(w, a.se2, b.se2, e.measurement.se2, &f);
    } else {
      addChordalEdgeCost(w, a.se3, b.se3, e.measurement.se3, &f);
    }
  }
  return f;
}

FactorPtr makeEdgeFactor(const GraphFile& graph, const GraphEdge& e, Objective objective) {
  if (objective == Objective::kSeSync) {
    const SeSyncWeights w = seSyncWeights(e, graph.dimension);
    if (graph.dimension == 2) {
      return std::make_shared<ChordalRelativePose2Factor>(e.from, e.to, e.measurement.se2, w.kappa,
                                                          w.tau);
    }
    return std::make_shared<ChordalRelativePose3Factor>(e.from, e.to, e.measurement.se3, w.kappa,
                                                        w.tau);
  }
  const bool isam = graph.format == GraphFormat::kIsam;
  if (graph.dimension == 2) {
    return std::make_shared<RelativePose2Factor>(
        e.from, e.to, e.measurement.se2, e.sqrt_information,
        isam ? RelativePose2Factor::Convention::kIsam : RelativePose2Factor::Convention::kG2o);
  }
  return std::make_shared<RelativePose3Factor>(
      e.from, e.to, e.measurement.se3, e.sqrt_information,
      isam ? RelativePose3Factor::Convention::kIsamEuler : RelativePose3Factor::Convention::kG2o);
}

RobustKernel kernelForFactor(const RobustKernel& kernel, int dim) {
  RobustKernel k = kernel;
  if (k.type == KernelType::kGncTls && !(k.parameter > 0.0)) {
    k.parameter = chiSquareQuantile(dim, 0.99);
  }
  return k;
}

FactorPtr makeAnchorFactor(Key key, int dimension, double sqrt_information) {
  if (dimension == 2) {
    return std::make_shared<PosePrior2Factor>(key, core::SE2d(),
                                              sqrt_information * Eigen::MatrixXd::Identity(3, 3));
  }
  return std::make_shared<PosePrior3Factor>(key, core::SE3d(),
                                            sqrt_information * Eigen::MatrixXd::Identity(6, 6));
}

bool isOdometryEdge(const GraphEdge& e) { return e.to - e.from == 1 || e.from - e.to == 1; }

Key firstPoseId(const GraphFile& graph) {
  if (!graph.vertices.empty()) return graph.vertices.front().id;
  if (!graph.edges.empty()) return graph.edges.front().from;
  return 0;
}

namespace {

PoseValue identityPose(int dimension) {
  return dimension == 2 ? PoseValue::planar(core::SE2d()) : PoseValue::spatial(core::SE3d());
}

}  // namespace

FactorPtr makeObservationFactor(const GraphFile& graph, const GraphObservation& o) {
  if (graph.dimension == 2) {
    return std::make_shared<PosePoint2Factor>(o.pose, o.landmark, o.measured.head<2>(),
                                              o.sqrt_information);
  }
  return std::make_shared<PosePoint3Factor>(o.pose, o.landmark, o.measured, o.sqrt_information,
                                            o.pose_T_sensor);
}

Status addLandmarkInitialization(const GraphFile& graph, bool file_positions, Values* values) {
  if (file_positions) {
    for (const GraphLandmark& l : graph.landmarks) {
      if (values->contains(l.id))
        return makeError(graph.path, ": vertex ", l.id, " is both a pose and a landmark");
      values->add(l.id, l.position);
    }
  }
  for (const GraphObservation& o : graph.observations) {
    const int p = values->indexOf(o.pose);
    if (p < 0 || values->at(p).isPoint()) {
      return makeError(graph.path, ":", o.line, ": landmark ", o.landmark, " observed from ",
                       p < 0 ? "pose " : "landmark ", o.pose,
                       p < 0 ? ", which no edge connects to the first pose" : " (not a pose)");
    }
    const int l = values->indexOf(o.landmark);
    if (l >= 0) {
      if (!values->at(l).isPoint()) {
        return makeError(graph.path, ":", o.line, ": landmark id ", o.landmark, " is a pose");
      }
      continue;
    }
    values->add(o.landmark, observationInitialValue(values->at(p), o.measured, o.pose_T_sensor));
  }
  return Ok{};
}

Expected<Values> odometryInitialization(const GraphFile& graph) {
  auto values = odometryPoseInitialization(graph);
  if (!values.ok()) return values;
  if (auto st = addLandmarkInitialization(graph, false, &*values); !st.ok()) return st.error();
  return values;
}

Expected<Values> odometryPoseInitialization(const GraphFile& graph) {
  std::map<Key, PoseValue> pose;
  pose[firstPoseId(graph)] = identityPose(graph.dimension);
  std::vector<Key> order = {firstPoseId(graph)};
  // File order, like iSAM; repeated passes catch edges that arrive before their anchor.
  bool progress = true;
  while (progress) {
    progress = false;
    for (const GraphEdge& e : graph.edges) {
      const bool has_from = pose.count(e.from) != 0;
      const bool has_to = pose.count(e.to) != 0;
      if (has_from && !has_to) {
        pose[e.to] = compose(pose[e.from], e.measurement);
        order.push_back(e.to);
        progress = true;
      } else if (!has_from && has_to) {
        pose[e.from] = compose(pose[e.to], inverse(e.measurement));
        order.push_back(e.from);
        progress = true;
      }
    }
  }
  for (const GraphEdge& e : graph.edges) {
    if (!pose.count(e.from) || !pose.count(e.to)) {
      return makeError(graph.path, ":", e.line, ": edge ", e.from, "-", e.to,
                       " is not connected to pose ", firstPoseId(graph));
    }
  }
  for (const GraphVertex& v : graph.vertices) {
    if (!pose.count(v.id)) {
      return makeError(graph.path, ": vertex ", v.id, " has no path of edges to pose ",
                       firstPoseId(graph));
    }
  }
  Values values;
  for (Key k : order) values.add(k, pose[k]);
  return values;
}

Expected<Values> fileInitialization(const GraphFile& graph) {
  Values values;
  for (const GraphVertex& v : graph.vertices) values.add(v.id, v.pose);
  for (const GraphEdge& e : graph.edges) {
    if (!values.contains(e.from) || !values.contains(e.to)) {
      return makeError(graph.path, ":", e.line, ": edge refers to a pose without a VERTEX line");
    }
  }
  if (values.size() == 0) return makeError(graph.path, ": has no VERTEX lines");
  if (auto st = addLandmarkInitialization(graph, true, &values); !st.ok()) return st.error();
  return values;
}

Expected<PoseGraph> buildPoseGraph(const GraphFile& graph, const Values& initial,
                                   const BuildOptions& options) {
  PoseGraph g;
  for (int i = 0; i < initial.size(); ++i) {
    if (auto st = g.addVariable(initial.keyAt(i), initial.at(i)); !st.ok()) return st.error();
  }
  if (options.anchor) {
    auto id = g.addFactor(makeAnchorFactor(firstPoseId(graph), graph.dimension));
    if (!id.ok()) return id.error();
  }
  if (auto st = checkInformation(graph, options.objective); !st.ok()) return st.error();
  for (const GraphEdge& e : graph.edges) {
    FactorPtr f = makeEdgeFactor(graph, e, options.objective);
    if (options.kernel.active() && (options.robust_odometry || !isOdometryEdge(e))) {
      f->setKernel(kernelForFactor(options.kernel, f->dim()));
    }
    auto id = g.addFactor(std::move(f));
    if (!id.ok()) return makeError(graph.path, ":", e.line, ": ", id.error().message);
  }
  for (const GraphObservation& o : graph.observations) {
    FactorPtr f = makeObservationFactor(graph, o);
    if (options.kernel.active() && options.robust_odometry) {
      f->setKernel(kernelForFactor(options.kernel, f->dim()));
    }
    auto id = g.addFactor(std::move(f));
    if (!id.ok()) return makeError(graph.path, ":", o.line, ": ", id.error().message);
  }
  return g;
}

}  // namespace evermap::solver
