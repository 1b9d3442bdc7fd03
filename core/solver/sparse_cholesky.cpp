#include "core/solver/sparse_cholesky.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include <cholmod.h>

#include "core/solver/square_root_factor.h"

namespace evermap::solver {

// ---------------------------------------------------------------- BlockPattern

BlockPattern::BlockPattern(std::vector<int> dims, std::vector<std::pair<int, int>> pairs)
    : dims_(std::move(dims)) {
  const int n = numBlocks();
  offsets_.assign(n + 1, 0);
  for (int b = 0; b < n; ++b) offsets_[b + 1] = offsets_[b] + dims_[b];
  upper_.assign(n, {});
  for (auto [i, j] : pairs) {
    if (i == j) continue;
    if (i > j) std::swap(i, j);
    upper_[j].push_back(i);
  }
  upper_row_offset_.assign(n, {});
  col_ptr_.assign(scalarSize() + 1, 0);
  int64_t nnz = 0;
  for (int j = 0; j < n; ++j) {
    auto& u = upper_[j];
    std::sort(u.begin(), u.end());
    u.erase(std::unique(u.begin(), u.end()), u.end());
    int rows = 0;
    for (int i : u) {
      upper_row_offset_[j].push_back(rows);
      rows += dims_[i];
    }
    for (int q = 0; q < dims_[j]; ++q) {
      col_ptr_[offsets_[j] + q] = static_cast<int>(nnz);
      nnz += rows + q + 1;
    }
  }
  col_ptr_[scalarSize()] = static_cast<int>(nnz);
  row_idx_.resize(nnz);
  for (int j = 0; j < n; ++j) {
    for (int q = 0; q < dims_[j]; ++q) {
      int k = col_ptr_[offsets_[j] + q];
      for (int i : upper_[j]) {
        for (int a = 0; a < dims_[i]; ++a) row_idx_[k++] = offsets_[i] + a;
      }
      for (int a = 0; a <= q; ++a) row_idx_[k++] = offsets_[j] + a;
    }
  }
}

void BlockPattern::addBlock(int i, int j, const Eigen::Ref<const Eigen::MatrixXd>& M,
                            double* values) const {
  if (i == j) {
    const int rows = col_ptr_[offsets_[j] + 1] - col_ptr_[offsets_[j]] - 1;  // off-diag rows
    for (int q = 0; q < dims_[j]; ++q) {
      double* col = values + col_ptr_[offsets_[j] + q] + rows;
      for (int a = 0; a <= q; ++a) col[a] += M(a, q);
    }
    return;
  }
  const auto& u = upper_[j];
  const auto it = std::lower_bound(u.begin(), u.end(), i);
  if (it == u.end() || *it != i) {
    std::fprintf(stderr, "evermap: BlockPattern::addBlock: block (%d, %d) not in pattern\n", i, j);
    std::abort();
  }
  const int row_off = upper_row_offset_[j][it - u.begin()];
  for (int q = 0; q < dims_[j]; ++q) {
    double* col = values + col_ptr_[offsets_[j] + q] + row_off;
    for (int a = 0; a < dims_[i]; ++a) col[a] += M(a, q);
  }
}

void BlockPattern::multiplyAdd(const double* values, const Eigen::VectorXd& x,
                               Eigen::VectorXd* y) const {
  for (int c = 0; c < scalarSize(); ++c) {
    for (int k = col_ptr_[c]; k < col_ptr_[c + 1]; ++k) {
      const int r = row_idx_[k];
      (*y)[r] += values[k] * x[c];
      if (r != c) (*y)[c] += values[k] * x[r];
    }
  }
}

// ---------------------------------------------------------------- SparseCholesky

struct SparseCholesky::Impl {
  cholmod_common common;
  cholmod_sparse* H = nullptr;
  cholmod_factor* L = nullptr;
  std::vector<double> base_diagonal;

  Impl() {
    cholmod_start(&common);
    common.print = 0;
    common.nmethods = 1;
    common.method[0].ordering = CHOLMOD_GIVEN;
    common.postorder = 1;
    common.supernodal = CHOLMOD_SUPERNODAL;
  }
  ~Impl() {
    release();
    cholmod_finish(&common);
  }
  void release() {
    if (L) cholmod_free_factor(&L, &common);
    if (H) cholmod_free_sparse(&H, &common);
  }
};

SparseCholesky::SparseCholesky() : impl_(std::make_unique<Impl>()) {}
SparseCholesky::~SparseCholesky() = default;

void SparseCholesky::analyze(const BlockPattern& pattern, std::span<const int> block_order) {
  impl_->release();
  pattern_ = std::make_unique<BlockPattern>(pattern);
  cholmod_common* c = &impl_->common;
  const int n = pattern.scalarSize();
  impl_->H = cholmod_allocate_sparse(n, n, pattern.nnz(), 1, 1, 1, CHOLMOD_REAL, c);
  int* Hp = static_cast<int*>(impl_->H->p);
  int* Hi = static_cast<int*>(impl_->H->i);
  std::copy(pattern.colPtr().begin(), pattern.colPtr().end(), Hp);
  std::copy(pattern.rowIdx().begin(), pattern.rowIdx().end(), Hi);
  zeroValues();

  std::vector<int> perm;
  perm.reserve(n);
  for (int b : block_order) {
    for (int a = 0; a < pattern.dim(b); ++a) perm.push_back(pattern.offset(b) + a);
  }
  impl_->L = cholmod_analyze_p(impl_->H, perm.data(), nullptr, 0, c);
  if (!impl_->L) {
    std::fprintf(stderr, "evermap: CHOLMOD analysis failed (status %d)\n", c->status);
    std::abort();
  }
  // Post-ordering keeps the columns of a block together (they are a chain in the elimination
  // tree); recover the block order from the final scalar permutation.
  std::vector<int> block_of(n);
  for (int b = 0; b < pattern.numBlocks(); ++b) {
    for (int a = 0; a < pattern.dim(b); ++a) block_of[pattern.offset(b) + a] = b;
  }
  const int* P = static_cast<const int*>(impl_->L->Perm);
  final_order_.clear();
  for (int k = 0; k < n;) {
    const int b = block_of[P[k]];
    for (int a = 0; a < pattern.dim(b); ++a) {
      if (block_of[P[k + a]] != b) {
        std::fprintf(stderr, "evermap: CHOLMOD post-ordering split a variable block\n");
        std::abort();
      }
    }
    final_order_.push_back(b);
    k += pattern.dim(b);
  }
}

double* SparseCholesky::values() { return static_cast<double*>(impl_->H->x); }

void SparseCholesky::zeroValues() { std::fill_n(values(), pattern_->nnz(), 0.0); }

Status SparseCholesky::factorize(const Eigen::VectorXd& extra_diagonal) {
  cholmod_common* c = &impl_->common;
  double* x = values();
  const auto& cp = pattern_->colPtr();
  const int n = pattern_->scalarSize();
  if (extra_diagonal.size() == n) {
    // The diagonal is the last entry of each column of the upper triangle.
    impl_->base_diagonal.resize(n);
    for (int j = 0; j < n; ++j) {
      impl_->base_diagonal[j] = x[cp[j + 1] - 1];
      x[cp[j + 1] - 1] += extra_diagonal[j];
    }
  }
  cholmod_factorize(impl_->H, impl_->L, c);
  if (extra_diagonal.size() == n) {
    for (int j = 0; j < n; ++j) x[cp[j + 1] - 1] = impl_->base_diagonal[j];
  }
  if (c->status == CHOLMOD_NOT_POSDEF || impl_->L->minor < static_cast<size_t>(n)) {
    return makeError(
        "normal equations are not positive definite (a variable or the gauge "
        "is not constrained by the factors, or the estimate diverged)");
  }
  if (c->status < 0) return makeError("CHOLMOD factorisation failed (status ", c->status, ")");
  return Ok{};
}

Eigen::VectorXd SparseCholesky::solve(const Eigen::VectorXd& rhs) {
  cholmod_common* c = &impl_->common;
  const int n = pattern_->scalarSize();
  cholmod_dense b;
  b.nrow = n;
  b.ncol = 1;
  b.nzmax = n;
  b.d = n;
  b.x = const_cast<double*>(rhs.data());
  b.z = nullptr;
  b.xtype = CHOLMOD_REAL;
  b.dtype = CHOLMOD_DOUBLE;
  cholmod_dense* x = cholmod_solve(CHOLMOD_A, impl_->L, &b, c);
  Eigen::VectorXd out = Eigen::Map<Eigen::VectorXd>(static_cast<double*>(x->x), n);
  cholmod_free_dense(&x, c);
  return out;
}

int64_t SparseCholesky::factorNnz() const {
  const cholmod_factor* L = impl_->L;
  if (!L) return 0;
  if (L->is_super) {
    const int* pi = static_cast<const int*>(L->pi);
    const int* super = static_cast<const int*>(L->super);
    int64_t nnz = 0;
    for (size_t s = 0; s < L->nsuper; ++s) {
      const int64_t cols = super[s + 1] - super[s];
      const int64_t rows = pi[s + 1] - pi[s];
      nnz += cols * rows - cols * (cols - 1) / 2;
    }
    return nnz;
  }
  return static_cast<int64_t>(L->nzmax);
}

void SparseCholesky::extractSquareRoot(SquareRootFactor* R) const {
  const cholmod_factor* L = impl_->L;
  const BlockPattern& pat = *pattern_;
  const int n = pat.scalarSize();
  R->clear();
  // Scalar position -> block position, and the scalar position where each block starts.
  std::vector<int> block_pos_of(n);
  std::vector<int> start_of_pos;
  int k = 0;
  for (size_t p = 0; p < final_order_.size(); ++p) {
    const int d = pat.dim(final_order_[p]);
    R->appendPosition(d);
    start_of_pos.push_back(k);
    for (int a = 0; a < d; ++a) block_pos_of[k + a] = static_cast<int>(p);
    k += d;
  }
  // Column j of the supernodal L: rows Ls[pi[s] + jj ...], values Lx[px[s] + jj*nsrow + ...].
  const int* super = static_cast<const int*>(L->super);
  const int* pi = static_cast<const int*>(L->pi);
  const int* px = static_cast<const int*>(L->px);
  const int* Ls = static_cast<const int*>(L->s);
  const double* Lx = static_cast<const double*>(L->x);
  std::vector<int> super_of(n);
  for (size_t s = 0; s < L->nsuper; ++s) {
    for (int j = super[s]; j < super[s + 1]; ++j) super_of[j] = static_cast<int>(s);
  }
  for (size_t p = 0; p < final_order_.size(); ++p) {
    SquareRootFactor::Row& row = R->mutableRow(static_cast<int>(p));
    const int j0 = start_of_pos[p];
    const int s0 = super_of[j0];
    const int nsrow0 = pi[s0 + 1] - pi[s0];
    const int jj0 = j0 - super[s0];
    // Block structure from the first column of the block (the widest).
    row.cols.clear();
    for (int r = jj0; r < nsrow0; ++r) {
      const int bp = block_pos_of[Ls[pi[s0] + r]];
      if (row.cols.empty() || row.cols.back() != bp) row.cols.push_back(bp);
    }
    row.offsets.assign(row.cols.size() + 1, 0);
    for (size_t c = 0; c < row.cols.size(); ++c) {
      row.offsets[c + 1] = row.offsets[c] + R->dimAt(row.cols[c]);
    }
    row.uniform = row.offsets.back() == static_cast<int>(row.cols.size()) * row.dim;
    row.A = SquareRootFactor::RowMatrix::Zero(row.dim, row.offsets.back());
    row.d = Eigen::VectorXd::Zero(row.dim);
    row.initialized = true;
    for (int a = 0; a < row.dim; ++a) {
      const int j = j0 + a;
      const int s = super_of[j];
      const int nsrow = pi[s + 1] - pi[s];
      const int jj = j - super[s];
      const double* col = Lx + px[s] + static_cast<int64_t>(jj) * nsrow;
      size_t c = 0;
      for (int r = jj; r < nsrow; ++r) {
        const int i = Ls[pi[s] + r];
        const int bp = block_pos_of[i];
        while (c < row.cols.size() && row.cols[c] != bp) ++c;
        if (c == row.cols.size()) {
          std::fprintf(stderr, "evermap: CHOLMOD factor column outside its block structure\n");
          std::abort();
        }
        row.A(a, row.offsets[c] + (i - start_of_pos[bp])) = col[r];
      }
    }
  }
  R->rebuildUsers();
}

}  // namespace evermap::solver
