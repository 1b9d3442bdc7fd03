#include "core/solver/square_root_factor.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace evermap::solver {
namespace {

// A pivot this small relative to its row means the variable is not determined.
constexpr double kPivotTolerance = 1e-12;

}  // namespace

void SquareRootFactor::clear() {
  rows_.clear();
  users_.clear();
  scalar_offsets_.assign(1, 0);
}

int SquareRootFactor::appendPosition(int dim) {
  if (dim < 1 || dim > kMaxBlockDim) {
    std::fprintf(stderr, "evermap: SquareRootFactor: block dimension %d out of range\n", dim);
    std::abort();
  }
  users_.emplace_back();
  Row r;
  r.dim = dim;
  rows_.push_back(std::move(r));
  scalar_offsets_.push_back(scalar_offsets_.back() + dim);
  return size() - 1;
}

void SquareRootFactor::rebuildUsers() {
  users_.assign(rows_.size(), {});
  for (int p = 0; p < size(); ++p) {
    for (size_t c = 1; c < rows_[p].cols.size(); ++c) users_[rows_[p].cols[c]].push_back(p);
  }
}

int SquareRootFactor::parent(int position) const {
  const Row& r = rows_[position];
  return r.cols.size() > 1 ? r.cols[1] : -1;
}

void SquareRootFactor::relayout(int position, const std::vector<int>& cols) {
  Row* row = &rows_[position];
  // Record the new block columns' users (rows that read them in back substitution).
  {
    size_t o = 0;
    for (size_t c = 1; c < cols.size(); ++c) {
      while (o < row->cols.size() && row->cols[o] < cols[c]) ++o;
      if (o == row->cols.size() || row->cols[o] != cols[c]) users_[cols[c]].push_back(position);
    }
  }
  std::vector<int> offsets(cols.size() + 1, 0);
  for (size_t c = 0; c < cols.size(); ++c) offsets[c + 1] = offsets[c] + rows_[cols[c]].dim;
  RowMatrix A = RowMatrix::Zero(row->dim, offsets.back());
  if (row->initialized) {
    size_t c = 0;
    for (size_t o = 0; o < row->cols.size(); ++o) {
      while (cols[c] != row->cols[o]) ++c;
      const int w = row->offsets[o + 1] - row->offsets[o];
      A.middleCols(offsets[c], w) = row->A.middleCols(row->offsets[o], w);
    }
  } else {
    row->d = Eigen::VectorXd::Zero(row->dim);
    row->initialized = true;
  }
  row->A.swap(A);
  row->cols = cols;
  row->uniform = offsets.back() == static_cast<int>(cols.size()) * row->dim;
  row->offsets = std::move(offsets);
}

namespace {

// One Householder reflection that zeroes column j of the new rows W (column-major,
// m × width) against R(j, j), applied to row j of R (Rj), to W's columns j+1.., and to the
// right-hand sides. M is m at compile time (0: only known at run time); plain loops, since
// m is 1..12 and the rows are short.
template <int M>
void reflect(int m_runtime, int j, int width, double* W, double* Rj, double* dj, double* rhs) {
  const int m = M > 0 ? M : m_runtime;
  double* v = W + static_cast<int64_t>(j) * m;
  double norm2 = 0.0;
  for (int r = 0; r < m; ++r) norm2 += v[r] * v[r];
  if (norm2 == 0.0) return;
  const double alpha = Rj[j];
  const double sigma = std::sqrt(alpha * alpha + norm2);
  const double beta = alpha > 0.0 ? -sigma : sigma;
  const double u0 = alpha - beta;
  // Reflector u = (1, v / u0), H = I − τ u uᵀ with τ = −u0 / β.
  const double inv_u0 = 1.0 / u0;
  for (int r = 0; r < m; ++r) v[r] *= inv_u0;
  const double tau = -u0 / beta;
  for (int c = j + 1; c < width; ++c) {
    double* wc = W + static_cast<int64_t>(c) * m;
    double s = Rj[c];
    for (int r = 0; r < m; ++r) s += v[r] * wc[r];
    s *= tau;
    Rj[c] -= s;
    for (int r = 0; r < m; ++r) wc[r] -= s * v[r];
  }
  double s = *dj;
  for (int r = 0; r < m; ++r) s += v[r] * rhs[r];
  s *= tau;
  *dj -= s;
  for (int r = 0; r < m; ++r) rhs[r] -= s * v[r];
  Rj[j] = beta;
  for (int r = 0; r < m; ++r) v[r] = 0.0;
}

}  // namespace

double SquareRootFactor::addRows(std::span<const int> positions,
                                 const Eigen::Ref<const Eigen::MatrixXd>& A,
                                 const Eigen::Ref<const Eigen::VectorXd>& b,
                                 std::vector<int>* touched) {
  const int m = static_cast<int>(A.rows());
  std::vector<int>& S = structure_;
  S.assign(positions.begin(), positions.end());
  work_ = A;     // column-major: each scalar column of the new rows is contiguous
  int base = 0;  // work_ columns [base, ...) belong to S
  rhs_ = b;
  double* rhs = rhs_.data();

  while (!S.empty()) {
    const int k = S.front();
    Row& R = rows_[k];
    const int d = R.dim;
    if (touched) touched->push_back(k);

    // Union of the row's structure and the new rows' structure: fill-in of R.
    merged_.clear();
    if (R.initialized) {
      std::set_union(R.cols.begin(), R.cols.end(), S.begin(), S.end(), std::back_inserter(merged_));
    } else {
      merged_ = S;
    }
    if (!R.initialized || merged_.size() != R.cols.size()) relayout(k, merged_);
    const int width = static_cast<int>(R.A.cols());

    // Bring the new rows to the same layout.
    if (S.size() != merged_.size()) {
      work_next_.setZero(m, width);
      size_t c = 0;
      int src = base;
      for (int sp : S) {
        while (merged_[c] != sp) ++c;
        const int w = rows_[sp].dim;
        work_next_.middleCols(R.offsets[c], w) = work_.middleCols(src, w);
        src += w;
      }
      work_.swap(work_next_);
      base = 0;
    }

    // One Householder reflection per column j zeroes the new rows' column j against R(j, j).
    double* W = work_.data() + static_cast<int64_t>(base) * m;
    for (int j = 0; j < d; ++j) {
      double* Rj = R.A.data() + static_cast<int64_t>(j) * width;
      if (m == 3) {
        reflect<3>(3, j, width, W, Rj, &R.d[j], rhs);
      } else if (m == 6) {
        reflect<6>(6, j, width, W, Rj, &R.d[j], rhs);
      } else {
        reflect<0>(m, j, width, W, Rj, &R.d[j], rhs);
      }
    }

    // The new rows now start at the next block column.
    S.assign(merged_.begin() + 1, merged_.end());
    base += d;
  }
  return rhs_.squaredNorm();
}

Status SquareRootFactor::backSubstitute(Eigen::VectorXd* x) const {
  std::vector<char> dirty(rows_.size(), 1);
  x->setZero(scalarSize());
  auto n = backSubstitutePartial(dirty, 0.0, x);
  if (!n.ok()) return n.error();
  return Ok{};
}

// acc −= Σ_{c ≥ 1} R_pc x_c for a row whose blocks all have dimension D (compile-time
// sizes let the compiler unroll the 3x3 / 6x6 products).
template <int D>
void SquareRootFactor::subtractBlocks(const Row& R, const double* x, double* acc) const {
  const int width = static_cast<int>(R.A.cols());
  const double* Ad = R.A.data();
  double sum[D] = {};
  for (size_t c = 1; c < R.cols.size(); ++c) {
    const double* xc = x + scalar_offsets_[R.cols[c]];
    const int o = static_cast<int>(c) * D;
    for (int j = 0; j < D; ++j) {
      const double* a = Ad + static_cast<int64_t>(j) * width + o;
      double s = 0.0;
      for (int k = 0; k < D; ++k) s += a[k] * xc[k];
      sum[j] += s;
    }
  }
  for (int j = 0; j < D; ++j) acc[j] -= sum[j];
}

Expected<int> SquareRootFactor::backSubstitutePartial(const std::vector<char>& dirty,
                                                      double threshold, Eigen::VectorXd* x) const {
  if (x->size() != scalarSize()) x->conservativeResizeLike(Eigen::VectorXd::Zero(scalarSize()));
  // Rows are solved from the last position down; a row is redone when its right-hand side
  // changed (dirty) or a variable it reads moved by more than the threshold (users_ lists
  // who reads each position, so a change marks exactly the rows to redo).
  pending_.assign(dirty.begin(), dirty.end());
  pending_.resize(rows_.size(), 0);
  int recomputed = 0;
  double* xd = x->data();
  double acc[kMaxBlockDim];
  for (int p = size() - 1; p >= 0; --p) {
    if (!pending_[p]) continue;
    const Row& R = rows_[p];
    ++recomputed;
    if (!R.initialized) {
      return makeError("square-root factor: variable at position ", p, " has no factor");
    }
    // acc = d − Σ_c R_pc x_c with plain loops: the blocks are 3x3 or 6x6, too small for a
    // library matrix-vector product to pay off.
    const int d = R.dim;
    const int width = static_cast<int>(R.A.cols());
    for (int j = 0; j < d; ++j) acc[j] = R.d[j];
    const double* Ad = R.A.data();
    if (R.uniform && d == 3) {
      subtractBlocks<3>(R, xd, acc);
    } else if (R.uniform && d == 6) {
      subtractBlocks<6>(R, xd, acc);
    } else {
      for (size_t c = 1; c < R.cols.size(); ++c) {
        const double* xc = xd + scalar_offsets_[R.cols[c]];
        const int o = R.offsets[c];
        const int w = R.offsets[c + 1] - o;
        for (int j = 0; j < d; ++j) {
          const double* a = Ad + static_cast<int64_t>(j) * width + o;
          double s = 0.0;
          for (int k = 0; k < w; ++k) s += a[k] * xc[k];
          acc[j] -= s;
        }
      }
    }
    // Upper-triangular solve of the diagonal block.
    double* xp = xd + scalar_offsets_[p];
    double change = 0.0;
    double scale = 0.0;
    for (int j = 0; j < d; ++j)
      scale = std::max(scale, std::abs(Ad[static_cast<int64_t>(j) * width + j]));
    for (int j = d - 1; j >= 0; --j) {
      const double* a = Ad + static_cast<int64_t>(j) * width;
      double s = acc[j];
      for (int c = j + 1; c < d; ++c) s -= a[c] * xp[c];
      const double pivot = a[j];
      if (!(std::abs(pivot) > kPivotTolerance * scale) || !std::isfinite(pivot)) {
        return makeError("square-root factor: zero pivot at position ", p,
                         " (a variable is not determined by its factors)");
      }
      const double v = s / pivot;
      change = std::max(change, std::abs(v - xp[j]));
      xp[j] = v;
    }
    if (change > threshold) {
      for (int r : users_[p]) pending_[r] = 1;
    }
  }
  return recomputed;
}

Eigen::VectorXd SquareRootFactor::multiply(const Eigen::VectorXd& x) const {
  Eigen::VectorXd y = Eigen::VectorXd::Zero(scalarSize());
  for (int p = 0; p < size(); ++p) {
    const Row& R = rows_[p];
    if (!R.initialized) continue;
    auto yp = y.segment(scalar_offsets_[p], R.dim);
    for (size_t c = 0; c < R.cols.size(); ++c) {
      const int w = R.offsets[c + 1] - R.offsets[c];
      yp.noalias() += R.A.middleCols(R.offsets[c], w) * x.segment(scalar_offsets_[R.cols[c]], w);
    }
  }
  return y;
}

Eigen::VectorXd SquareRootFactor::multiplyTranspose(const Eigen::VectorXd& y) const {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(scalarSize());
  for (int p = 0; p < size(); ++p) {
    const Row& R = rows_[p];
    if (!R.initialized) continue;
    const auto yp = y.segment(scalar_offsets_[p], R.dim);
    for (size_t c = 0; c < R.cols.size(); ++c) {
      const int w = R.offsets[c + 1] - R.offsets[c];
      x.segment(scalar_offsets_[R.cols[c]], w).noalias() +=
          R.A.middleCols(R.offsets[c], w).transpose() * yp;
    }
  }
  return x;
}

Eigen::VectorXd SquareRootFactor::rhs() const {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(scalarSize());
  for (int p = 0; p < size(); ++p) {
    if (rows_[p].initialized) d.segment(scalar_offsets_[p], rows_[p].dim) = rows_[p].d;
  }
  return d;
}

Eigen::VectorXd SquareRootFactor::solveTranspose(const Eigen::VectorXd& g) const {
  Eigen::VectorXd acc = g;
  for (int p = 0; p < size(); ++p) {
    const Row& R = rows_[p];
    if (!R.initialized) continue;
    auto yp = acc.segment(scalar_offsets_[p], R.dim);
    // Lower-triangular solve with the transposed diagonal block.
    for (int j = 0; j < R.dim; ++j) {
      double s = yp[j];
      for (int i = 0; i < j; ++i) s -= R.A(i, j) * yp[i];
      yp[j] = s / R.A(j, j);
    }
    for (size_t c = 1; c < R.cols.size(); ++c) {
      const int w = R.offsets[c + 1] - R.offsets[c];
      acc.segment(scalar_offsets_[R.cols[c]], w).noalias() -=
          R.A.middleCols(R.offsets[c], w).transpose() * yp;
    }
  }
  return acc;
}

void SquareRootFactor::setRhs(const Eigen::VectorXd& d) {
  for (int p = 0; p < size(); ++p) {
    if (rows_[p].initialized) rows_[p].d = d.segment(scalar_offsets_[p], rows_[p].dim);
  }
}

int64_t SquareRootFactor::nnz() const {
  int64_t n = 0;
  for (const Row& r : rows_) {
    if (!r.initialized) continue;
    // The diagonal block is triangular.
    n += static_cast<int64_t>(r.dim) * (r.A.cols() - r.dim) + r.dim * (r.dim + 1) / 2;
  }
  return n;
}

}  // namespace evermap::solver
