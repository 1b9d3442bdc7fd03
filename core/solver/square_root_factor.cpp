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
  scalar_offsets_.assign(1, 0);
}

int SquareRootFactor::appendPosition(int dim) {
  Row r;
  r.dim = dim;
  rows_.push_back(std::move(r));
  scalar_offsets_.push_back(scalar_offsets_.back() + dim);
  return size() - 1;
}

int SquareRootFactor::parent(int position) const {
  const Row& r = rows_[position];
  return r.cols.size() > 1 ? r.cols[1] : -1;
}

void SquareRootFactor::relayout(Row* row, const std::vector<int>& cols) const {
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
  row->offsets = std::move(offsets);
}

double SquareRootFactor::addRows(std::span<const int> positions,
                                 const Eigen::Ref<const Eigen::MatrixXd>& A,
                                 const Eigen::Ref<const Eigen::VectorXd>& b,
                                 std::vector<int>* touched) {
  const int m = static_cast<int>(A.rows());
  std::vector<int> S(positions.begin(), positions.end());
  work_ = A;  // row-major copy
  Eigen::VectorXd rhs = b;

  while (!S.empty()) {
    const int k = S.front();
    Row& R = rows_[k];
    const int d = R.dim;
    if (touched) touched->push_back(k);

    // Union of the row's structure and the new rows' structure: fill-in of R.
    merged_.clear();
    if (R.initialized) {
      std::set_union(R.cols.begin(), R.cols.end(), S.begin(), S.end(),
                     std::back_inserter(merged_));
    } else {
      merged_ = S;
    }
    if (!R.initialized || merged_.size() != R.cols.size()) relayout(&R, merged_);
    const int width = static_cast<int>(R.A.cols());

    // Bring the new rows to the same layout.
    if (S.size() != merged_.size()) {
      work_next_.setZero(m, width);
      size_t c = 0;
      int src = 0;
      for (int s : S) {
        while (merged_[c] != s) ++c;
        const int w = rows_[s].dim;
        work_next_.middleCols(R.offsets[c], w) = work_.middleCols(src, w);
        src += w;
      }
      work_.swap(work_next_);
    }

    // One Householder reflection per column j zeroes the new rows' column j against R(j, j).
    for (int j = 0; j < d; ++j) {
      double norm2 = 0.0;
      for (int r = 0; r < m; ++r) norm2 += work_(r, j) * work_(r, j);
      if (norm2 == 0.0) continue;
      const double alpha = R.A(j, j);
      const double sigma = std::sqrt(alpha * alpha + norm2);
      const double beta = alpha > 0.0 ? -sigma : sigma;
      const double u0 = alpha - beta;
      const double tau = -u0 / beta;  // 2 / (uᵀu) scaled for u0 = 1 below
      // Normalise u so that u0 = 1: v_r = work(r, j) / u0.
      const double inv_u0 = 1.0 / u0;
      for (int c = j + 1; c < width; ++c) {
        double s = R.A(j, c);
        for (int r = 0; r < m; ++r) s += inv_u0 * work_(r, j) * work_(r, c);
        s *= tau;
        R.A(j, c) -= s;
        for (int r = 0; r < m; ++r) work_(r, c) -= s * inv_u0 * work_(r, j);
      }
      double s = R.d[j];
      for (int r = 0; r < m; ++r) s += inv_u0 * work_(r, j) * rhs[r];
      s *= tau;
      R.d[j] -= s;
      for (int r = 0; r < m; ++r) rhs[r] -= s * inv_u0 * work_(r, j);
      R.A(j, j) = beta;
      for (int r = 0; r < m; ++r) work_(r, j) = 0.0;
    }

    // The new rows now start at the next block column.
    S.assign(merged_.begin() + 1, merged_.end());
    if (S.empty()) break;
    work_next_ = work_.rightCols(width - d);
    work_.swap(work_next_);
  }
  return rhs.squaredNorm();
}

Status SquareRootFactor::backSubstitute(Eigen::VectorXd* x) const {
  std::vector<char> dirty(rows_.size(), 1);
  x->setZero(scalarSize());
  auto n = backSubstitutePartial(dirty, 0.0, x);
  if (!n.ok()) return n.error();
  return Ok{};
}

Expected<int> SquareRootFactor::backSubstitutePartial(const std::vector<char>& dirty,
                                                      double threshold,
                                                      Eigen::VectorXd* x) const {
  if (x->size() != scalarSize()) x->conservativeResizeLike(Eigen::VectorXd::Zero(scalarSize()));
  // changed[p]: x at p moved by more than the threshold, so rows that read p must be redone.
  std::vector<char> changed(rows_.size(), 0);
  int recomputed = 0;
  Eigen::VectorXd acc;
  for (int p = size() - 1; p >= 0; --p) {
    const Row& R = rows_[p];
    bool redo = dirty[p] != 0;
    for (size_t c = 1; !redo && c < R.cols.size(); ++c) redo = changed[R.cols[c]] != 0;
    if (!redo) continue;
    ++recomputed;
    if (!R.initialized) return makeError("square-root factor: variable at position ", p,
                                         " has no factor");
    acc = R.d;
    for (size_t c = 1; c < R.cols.size(); ++c) {
      const int w = R.offsets[c + 1] - R.offsets[c];
      acc.noalias() -= R.A.middleCols(R.offsets[c], w) * x->segment(scalar_offsets_[R.cols[c]], w);
    }
    // Upper-triangular solve of the diagonal block.
    const int d = R.dim;
    auto xp = x->segment(scalar_offsets_[p], d);
    double change = 0.0;
    const double scale = R.A.row(0).cwiseAbs().maxCoeff();
    for (int j = d - 1; j >= 0; --j) {
      double s = acc[j];
      for (int c = j + 1; c < d; ++c) s -= R.A(j, c) * xp[c];
      const double pivot = R.A(j, j);
      if (!(std::abs(pivot) > kPivotTolerance * scale) || !std::isfinite(pivot)) {
        return makeError("square-root factor: zero pivot at position ", p,
                         " (a variable is not determined by its factors)");
      }
      const double v = s / pivot;
      change = std::max(change, std::abs(v - xp[j]));
      xp[j] = v;
    }
    changed[p] = change > threshold;
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
