#pragma once
// The normal equations H δ = g of a pose graph on CHOLMOD (SuiteSparse), block by block.
//
// BlockPattern is the upper triangle of H in CHOLMOD's compressed-column form, built from
// which variable blocks share a factor; H is filled block by block (addBlock) and factored
// by supernodal Cholesky, P H Pᵀ = L Lᵀ, with a block ordering the caller chooses
// (COLAMD/CCOLAMD in core/solver/ordering.h) expanded to scalars. The factor can be handed
// out as the block rows of R = Lᵀ for the incremental solver (core/solver/square_root_factor.h).

#include <memory>
#include <span>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"

namespace evermap::solver {

class SquareRootFactor;

class BlockPattern {
 public:
  // dims[b] = size of block b; pairs = unordered block pairs that share a factor (i != j);
  // every block has a diagonal entry.
  BlockPattern(std::vector<int> dims, std::vector<std::pair<int, int>> pairs);

  int numBlocks() const { return static_cast<int>(dims_.size()); }
  int dim(int b) const { return dims_[b]; }
  int offset(int b) const { return offsets_[b]; }
  int scalarSize() const { return offsets_.back(); }
  int64_t nnz() const { return col_ptr_.back(); }
  const std::vector<int>& colPtr() const { return col_ptr_; }
  const std::vector<int>& rowIdx() const { return row_idx_; }
  // Block rows i < j stored in block column j, ascending.
  const std::vector<int>& upperNeighbours(int j) const { return upper_[j]; }

  // values[...] += M for block (i, j), M = d_i × d_j; i <= j (the diagonal keeps only its
  // upper triangle). Contract: (i, j) is in the pattern.
  void addBlock(int i, int j, const Eigen::Ref<const Eigen::MatrixXd>& M, double* values) const;
  // y += H x for the symmetric H stored in values.
  void multiplyAdd(const double* values, const Eigen::VectorXd& x, Eigen::VectorXd* y) const;

 private:
  std::vector<int> dims_;
  std::vector<int> offsets_;
  std::vector<std::vector<int>> upper_;
  std::vector<std::vector<int>> upper_row_offset_;  // scalar row offset of each upper block
  std::vector<int> col_ptr_;
  std::vector<int> row_idx_;
};

// Owns the CHOLMOD state. Not copyable; one per solver.
class SparseCholesky {
 public:
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  // Symbolic analysis for a pattern and a block ordering (position -> block). Values are
  // zeroed; fill them with pattern().addBlock(..., values()).
  void analyze(const BlockPattern& pattern, std::span<const int> block_order);
  const BlockPattern& pattern() const { return *pattern_; }
  double* values();
  void zeroValues();

  // Numeric factorisation of H + diag(extra_diagonal) (extra may be empty). Errors when H is
  // not positive definite (an unconstrained gauge or a variable without enough factors).
  Status factorize(const Eigen::VectorXd& extra_diagonal = Eigen::VectorXd());
  // Solves (H + diag) x = rhs after factorize().
  Eigen::VectorXd solve(const Eigen::VectorXd& rhs);

  // Block order after CHOLMOD's post-ordering (position -> block).
  const std::vector<int>& blockOrder() const { return final_order_; }
  // R = Lᵀ as block rows in blockOrder() positions.
  void extractSquareRoot(SquareRootFactor* R) const;
  int64_t factorNnz() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::unique_ptr<BlockPattern> pattern_;
  std::vector<int> final_order_;
};

}  // namespace evermap::solver
