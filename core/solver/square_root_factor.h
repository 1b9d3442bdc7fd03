#pragma once
// The square-root information matrix R (upper triangular, RᵀR = AᵀA) and right-hand side d
// of a linearised pose graph, stored by block rows: one row block per variable, in
// elimination order ("positions"). This is the object iSAM updates incrementally
// (Kaess, Ranganathan & Dellaert, "iSAM: Incremental Smoothing and Mapping", T-RO 2008,
// section III): new measurement rows are eliminated into R by orthogonal transformations,
// so R stays the QR factor of the whole stacked Jacobian and the work follows the
// elimination-tree path from the new rows' first column to the root.
//
// We eliminate a new block row against the R row of its first block column with one
// Householder reflection per scalar column (equivalent to iSAM's sequence of Givens
// rotations — same result, fewer passes over the row).

#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"

namespace evermap::solver {

class SquareRootFactor {
 public:
  // Largest variable block (SE(3)).
  static constexpr int kMaxBlockDim = 6;
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  struct Row {
    int dim = 0;
    bool initialized = false;
    bool uniform = false;      // every block column has this row's dimension
    std::vector<int> cols;     // block columns (positions), ascending; cols[0] = own position
    std::vector<int> offsets;  // scalar offset of each block column inside A; back() = width
    RowMatrix A;               // dim × width; the diagonal block is upper triangular
    Eigen::VectorXd d;         // right-hand side rows
  };

  void clear();
  // Rebuilds the transpose structure after rows were set directly (mutableRow).
  void rebuildUsers();
  // Adds an empty row block for a new variable at the next position; returns the position.
  int appendPosition(int dim);
  int size() const { return static_cast<int>(rows_.size()); }
  const Row& row(int position) const { return rows_[position]; }
  Row& mutableRow(int position) { return rows_[position]; }
  int dimAt(int position) const { return rows_[position].dim; }
  int scalarOffset(int position) const { return scalar_offsets_[position]; }
  int scalarSize() const { return scalar_offsets_.back(); }
  // The elimination-tree parent of a position (its first off-diagonal block column), or -1.
  int parent(int position) const;

  // Eliminates new rows [A | b] into (R, d). `positions` are the rows' block columns,
  // ascending, A is m × (Σ dims of those positions). Returns ‖b_left‖², the squared
  // residual that no choice of the variables can remove (it adds to the cost constant).
  // Every position reached must exist. Positions whose rows get modified are appended to
  // *touched (if given), in ascending order.
  double addRows(std::span<const int> positions, const Eigen::Ref<const Eigen::MatrixXd>& A,
                 const Eigen::Ref<const Eigen::VectorXd>& b, std::vector<int>* touched = nullptr);

  // Solves R x = d (x stacked by scalarOffset). Errors on a (numerically) zero pivot:
  // some variable is not determined by the factors.
  Status backSubstitute(Eigen::VectorXd* x) const;
  // Partial back substitution (the "wildfire" of iSAM2): recomputes x only at positions whose
  // right-hand side changed (dirty) and, transitively, at positions whose block columns
  // changed by more than `threshold` (max-norm). threshold = 0 is the exact solve.
  // Returns the number of row blocks recomputed.
  Expected<int> backSubstitutePartial(const std::vector<char>& dirty, double threshold,
                                      Eigen::VectorXd* x) const;
  Eigen::VectorXd multiply(const Eigen::VectorXd& x) const;           // R x
  Eigen::VectorXd multiplyTranspose(const Eigen::VectorXd& y) const;  // Rᵀ y
  Eigen::VectorXd rhs() const;                                        // d stacked
  // Solves Rᵀ y = g (forward substitution), e.g. d = R⁻ᵀ Aᵀb after a batch factorisation.
  Eigen::VectorXd solveTranspose(const Eigen::VectorXd& g) const;
  void setRhs(const Eigen::VectorXd& d);
  int64_t nnz() const;

 private:
  void relayout(int position, const std::vector<int>& cols);
  template <int D>
  void subtractBlocks(const Row& R, const double* x, double* acc) const;

  std::vector<Row> rows_;
  // users_[c]: positions p < c whose row reads block column c (the transpose structure).
  std::vector<std::vector<int>> users_;
  std::vector<int> scalar_offsets_ = {0};
  // Scratch buffers for addRows (kept to avoid reallocating on every update).
  mutable std::vector<char> pending_;
  std::vector<int> merged_;
  std::vector<int> structure_;
  Eigen::MatrixXd work_;
  Eigen::MatrixXd work_next_;
  Eigen::VectorXd rhs_;
};

}  // namespace evermap::solver
