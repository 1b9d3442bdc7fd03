#include "core/solver/ordering.h"

#include <cstdio>
#include <cstdlib>

#include <ccolamd.h>

namespace evermap::solver {

std::vector<int> fillReducingOrder(int num_vars, const std::vector<std::vector<int>>& factor_vars,
                                   std::span<const int> constrained_last) {
  std::vector<int> order(num_vars);
  if (num_vars == 0) return order;
  const int n_row = static_cast<int>(factor_vars.size());
  // Column-major incidence: for each variable, the factors that touch it.
  std::vector<int> p(num_vars + 1, 0);
  int nnz = 0;
  for (const auto& vars : factor_vars) {
    for (int v : vars) ++p[v + 1];
    nnz += static_cast<int>(vars.size());
  }
  for (int v = 0; v < num_vars; ++v) p[v + 1] += p[v];
  const size_t alen = ccolamd_recommended(nnz, n_row, num_vars);
  std::vector<int> A(alen);
  std::vector<int> fill(p.begin(), p.end() - 1);
  for (int f = 0; f < n_row; ++f) {
    for (int v : factor_vars[f]) A[fill[v]++] = f;
  }
  std::vector<int> cmember;
  // CCOLAMD wants every constraint set non-empty: constrain only a proper subset.
  if (!constrained_last.empty() && static_cast<int>(constrained_last.size()) < num_vars) {
    cmember.assign(num_vars, 0);
    for (int v : constrained_last) cmember[v] = 1;
  }
  double knobs[CCOLAMD_KNOBS];
  ccolamd_set_defaults(knobs);
  int stats[CCOLAMD_STATS];
  const int ok = ccolamd(n_row, num_vars, static_cast<int>(alen), A.data(), p.data(), knobs, stats,
                         cmember.empty() ? nullptr : cmember.data());
  if (!ok) {
    std::fprintf(stderr, "evermap: CCOLAMD failed (status %d)\n", stats[CCOLAMD_STATUS]);
    std::abort();
  }
  for (int k = 0; k < num_vars; ++k) order[k] = p[k];
  return order;
}

}  // namespace evermap::solver
