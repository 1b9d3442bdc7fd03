// evermap-landmark-graph: writes a generated landmark problem in iSAM's text format
// (tools/sim/landmark_graphs.h), the stand-in for iSAM's cityTrees10000 / torus2000Points,
// which are not in the shared data. Only parses options; see docs/solver.md.
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "tools/sim/landmark_graphs.h"

namespace {

// The problem's settings (--help lists them, --print-config prints them).
struct LandmarkGraphOptions {
  int poses = 1000;
  uint64_t seed = 1;
  void declareOptions(evermap::OptionList& o) {
    o.add("poses", &poses, "", "poses of the generated problem").min(2);
    o.add("seed", &seed, "", "of the random draws").any();
  }
};

}  // namespace

int main(int argc, char** argv) {
  namespace sim = evermap::sim;
  std::vector<std::string> words;
  LandmarkGraphOptions o;
  evermap::CommandLine cli("evermap-landmark-graph",
                           "Writes a generated landmark problem in iSAM's text format.");
  cli.positional(&words, "city-trees|torus-points POSES FILE [SEED]",
                 "the kind of problem, its poses (or --set poses=N), the file to write and the "
                 "seed (or --set seed=S)");
  cli.options(&o);
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  // The old form's positional POSES and SEED are the options' values.
  for (size_t i : {size_t{1}, size_t{3}}) {
    if (i >= words.size()) continue;
    if (auto s = cli.optionList().set(i == 1 ? "poses" : "seed", words[i]); !s) {
      std::fprintf(stderr, "evermap-landmark-graph: %s\n", s.error().message.c_str());
      return 2;
    }
  }
  const std::string kind = words.empty() ? "" : words[0];
  if (words.size() < 3 || words.size() > 4 || (kind != "city-trees" && kind != "torus-points") ||
      o.poses < 2) {
    std::fprintf(stderr,
                 "evermap-landmark-graph: expected city-trees or torus-points, at least 2 poses "
                 "and FILE (--help)\n");
    return 2;
  }
  const sim::LandmarkGraph g = kind == "city-trees"
                                   ? sim::cityTreesLike(sim::cityTreesOptions(o.poses, o.seed))
                                   : sim::torusPointsLike(sim::torusPointsOptions(o.poses, o.seed));
  const std::string& file = words[2];
  std::ofstream out(file);
  out << g.isam_text;
  out.close();
  if (!out) {
    std::fprintf(stderr, "evermap-landmark-graph: %s: cannot write\n", file.c_str());
    return 1;
  }
  std::printf("%s: %d poses, %d landmarks, %d observations\n", file.c_str(), o.poses,
              g.observed_landmarks, g.observations);
  return 0;
}
