// evermap-landmark-graph: writes a generated landmark problem in iSAM's text format
// (tools/sim/landmark_graphs.h), the stand-in for iSAM's cityTrees10000 / torus2000Points,
// which are not in the shared data. Only parses options; see docs/solver.md.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "tools/sim/landmark_graphs.h"

int main(int argc, char** argv) {
  namespace sim = evermap::sim;
  if (argc < 4 || argc > 5) {
    std::fprintf(stderr,
                 "usage: evermap-landmark-graph city-trees|torus-points POSES FILE [SEED]\n");
    return 2;
  }
  const std::string kind = argv[1];
  const int poses = std::atoi(argv[2]);
  const uint64_t seed = argc == 5 ? std::strtoull(argv[4], nullptr, 10) : 1;
  if ((kind != "city-trees" && kind != "torus-points") || poses < 2) {
    std::fprintf(
        stderr,
        "evermap-landmark-graph: expected city-trees or torus-points and at least 2 poses\n");
    return 2;
  }
  const sim::LandmarkGraph g = kind == "city-trees"
                                   ? sim::cityTreesLike(sim::cityTreesOptions(poses, seed))
                                   : sim::torusPointsLike(sim::torusPointsOptions(poses, seed));
  std::ofstream out(argv[3]);
  out << g.isam_text;
  out.close();
  if (!out) {
    std::fprintf(stderr, "evermap-landmark-graph: %s: cannot write\n", argv[3]);
    return 1;
  }
  std::printf("%s: %d poses, %d landmarks, %d observations\n", argv[3], poses, g.observed_landmarks,
              g.observations);
  return 0;
}
