#pragma once
// The inputs a benchmark reads once (real data under EVERMAP_DATA), or nothing when they are
// missing: the benchmark is then skipped, saying why (`in.error`).

#include <benchmark/benchmark.h>

template <typename Inputs>
const Inputs* loadedInputs(benchmark::State& state, const Inputs& in) {
  if (in.error.empty()) return &in;
  state.SkipWithError(in.error.c_str());
  return nullptr;
}
