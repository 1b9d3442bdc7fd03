#pragma once
// What the solver tests share: a temporary graph file, and the check of a factor's analytic
// Jacobians against numerical ones.

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/solver/factor.h"
#include "core/solver/graph_io.h"

namespace evermap::testing {

// A file holding `content`, named after `name` and this process, removed at scope end.
class TempFile {
 public:
  TempFile(const std::string& name, const std::string& content)
      : path_(std::filesystem::temp_directory_path() /
              ("evermap_solver_" + std::to_string(::getpid()) + "_" + name)) {
    std::ofstream(path_) << content;
  }
  ~TempFile() { std::filesystem::remove(path_); }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// `content` read as a graph file from a TempFile named after `name`.
inline Expected<solver::GraphFile> readGraphText(
    const std::string& name, const std::string& content,
    solver::GraphFormat format = solver::GraphFormat::kAuto) {
  const TempFile f(name, content);
  return solver::readGraphFile(f.path(), format);
}

// Max |analytic − numerical| over all Jacobian blocks of a factor at x.
inline double jacobianError(const solver::Factor& f, const std::vector<solver::PoseValue>& x) {
  std::vector<const solver::PoseValue*> ptr;
  for (const auto& v : x) ptr.push_back(&v);
  std::vector<Eigen::MatrixXd> J;
  std::vector<double*> out;
  for (const auto& v : x) J.emplace_back(f.dim(), v.dim());
  for (auto& j : J) out.push_back(j.data());
  Eigen::VectorXd r(f.dim());
  f.evaluate(ptr, r.data(), out.data());
  const auto num = solver::numericalJacobians(f, ptr);
  double err = 0.0;
  for (size_t i = 0; i < J.size(); ++i) err = std::max(err, (J[i] - num[i]).cwiseAbs().maxCoeff());
  return err;
}

}  // namespace evermap::testing
