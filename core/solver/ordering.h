#pragma once
// Fill-reducing variable ordering for the square-root factor: CCOLAMD (SuiteSparse) on the
// block structure of the Jacobian (one row per factor, one column per variable), as iSAM
// orders its batch steps with COLAMD. Optionally a set of variables is constrained to come
// last (CCOLAMD's constraint sets), so that measurements on them touch few rows of R.

#include <span>
#include <vector>

namespace evermap::solver {

// Returns position -> variable. factor_vars[f] lists the variables of factor f.
std::vector<int> fillReducingOrder(int num_vars, const std::vector<std::vector<int>>& factor_vars,
                                   std::span<const int> constrained_last = {});

}  // namespace evermap::solver
