// g2o writer (declared in core/solver/graph_io.h).
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iomanip>

#include "core/solver/graph_io.h"
#include "core/solver/pose_factors.h"

namespace evermap::solver {
namespace {

// The information of an edge expressed for g2o's residual. TORO and g2o share the
// residual's meaning; iSAM's residual is r = M r_g2o to first order, so I_g2o = Mᵀ I M with
// M = diag(R_z, 1) in 2-D and M = diag(R_z, 2 ∂ypr/∂ε) in 3-D (q.xyz ≈ ε/2).
Eigen::MatrixXd g2oInformation(const GraphFile& g, const GraphEdge& e) {
  const Eigen::MatrixXd I = e.information();
  if (g.format != GraphFormat::kIsam) return I;
  if (g.dimension == 2) {
    Eigen::Matrix3d M = Eigen::Matrix3d::Identity();
    M.topLeftCorner<2, 2>() = e.measurement.se2.rotationMatrix();
    return M.transpose() * I * M;
  }
  Eigen::Matrix<double, 6, 6> M = Eigen::Matrix<double, 6, 6>::Zero();
  const core::Mat3 R = e.measurement.se3.rotationMatrix();
  M.topLeftCorner<3, 3>() = R;
  M.bottomRightCorner<3, 3>() = 2.0 * yawPitchRollJacobian(R);
  return M.transpose() * I * M;
}

void writePose(std::ostream& out, const PoseValue& p) {
  if (p.kind == PoseKind::kSE2) {
    out << p.se2.x() << ' ' << p.se2.y() << ' ' << p.se2.theta();
  } else {
    const auto& t = p.se3.translation();
    const auto& q = p.se3.quaternion();
    out << t.x() << ' ' << t.y() << ' ' << t.z() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z()
        << ' ' << q.w();
  }
}

}  // namespace

Status writeG2o(const std::filesystem::path& path, const GraphFile& graph, const Values& values) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp);
    if (!out) return makeError(tmp.string(), ": cannot open for writing");
    out << std::setprecision(17);
    // One sensor-offset parameter per id read, and an identity one for observations
    // without (iSAM's POINT3), under the first free id.
    int identity_param = 0;
    for (const auto& [id, offset] : graph.sensor_offsets) {
      identity_param = std::max(identity_param, id + 1);
      out << "PARAMS_SE3OFFSET " << id << ' ';
      writePose(out, PoseValue::spatial(offset));
      out << '\n';
    }
    bool need_identity = false;
    for (const GraphObservation& o : graph.observations) need_identity |= o.offset_param < 0;
    if (graph.dimension == 3 && need_identity) {
      out << "PARAMS_SE3OFFSET " << identity_param << " 0 0 0 0 0 0 1\n";
    }
    for (int i = 0; i < values.size(); ++i) {
      const PoseValue& p = values.at(i);
      if (p.isPoint()) {
        out << (p.kind == PoseKind::kPoint2 ? "VERTEX_XY " : "VERTEX_TRACKXYZ ") << values.keyAt(i)
            << ' ' << p.point.x() << ' ' << p.point.y();
        if (p.kind == PoseKind::kPoint3) out << ' ' << p.point.z();
        out << '\n';
        continue;
      }
      out << (p.kind == PoseKind::kSE2 ? "VERTEX_SE2 " : "VERTEX_SE3:QUAT ") << values.keyAt(i)
          << ' ';
      writePose(out, p);
      out << '\n';
    }
    for (const GraphEdge& e : graph.edges) {
      const bool planar = e.measurement.kind == PoseKind::kSE2;
      out << (planar ? "EDGE_SE2 " : "EDGE_SE3:QUAT ") << e.from << ' ' << e.to << ' ';
      writePose(out, e.measurement);
      const Eigen::MatrixXd I = g2oInformation(graph, e);
      for (int r = 0; r < I.rows(); ++r) {
        for (int c = r; c < I.cols(); ++c) out << ' ' << I(r, c);
      }
      out << '\n';
    }
    for (const GraphObservation& o : graph.observations) {
      const bool planar = graph.dimension == 2;
      out << (planar ? "EDGE_SE2_XY " : "EDGE_SE3_TRACKXYZ ") << o.pose << ' ' << o.landmark << ' ';
      if (!planar) out << (o.offset_param >= 0 ? o.offset_param : identity_param) << ' ';
      out << o.measured.x() << ' ' << o.measured.y();
      if (!planar) out << ' ' << o.measured.z();
      const Eigen::MatrixXd I = o.sqrt_information.transpose() * o.sqrt_information;
      for (int r = 0; r < I.rows(); ++r) {
        for (int c = r; c < I.cols(); ++c) out << ' ' << I(r, c);
      }
      out << '\n';
    }
    for (Key k : graph.fixed) out << "FIX " << k << '\n';
    out.flush();
    if (!out) return makeError(tmp.string(), ": write failed");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec)
    return makeError(path.string(), ": cannot rename from ", tmp.string(), ": ", ec.message());
  return Ok{};
}

}  // namespace evermap::solver
