// Place recognition at map scale: query and insertion time of a 10,000-place database, and the
// cost of quantising one image, with the default vocabulary (trained here from the shared
// images, k=10, L=5, as the tests and the demo do).
//
// The 10,000 places are synthesised from real descriptors: ORB descriptors (1000 per image)
// of the ~400 shared real images (the default training folders plus RTAB-Map's 84 samples).
// Place p starts from the descriptor set of a randomly drawn real image; each descriptor is
// then, with probability 0.2, replaced by a descriptor drawn from another random image (what
// changed or is seen anew), and otherwise has each bit flipped with probability 0.05 (about 13
// of 256 bits, the spread of ORB descriptors of one point seen again). Queries are revisits:
// a stored place perturbed once more the same way, so the inverted lists a query touches have
// the length they have in a real map. Revisit queries report how often the source place came
// first (a sanity check that the synthetic database is not degenerate).
//
// Figures: median and p99 over individually timed calls, wall clock (median_us, p99_us) and
// CPU time of the thread (cpu_median_us, cpu_p99_us), besides Google Benchmark's mean. Set
// EVERMAP_BOW_PLACES to change the database size.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <ctime>
#include <optional>

#include "core/bow/place_database.h"
#include "core/common/clocks.h"
#include "tools/vocab-train/image_training.h"
#include "tools/vocab-train/kmajority.h"

namespace {

namespace fs = std::filesystem;
using namespace evermap;
using namespace evermap::bow;
using Clock = std::chrono::steady_clock;

fs::path dataRoot() {
  const char* env = std::getenv("EVERMAP_DATA");
  return env && *env ? fs::path(env) : fs::path(EVERMAP_DATA_DEFAULT);
}

size_t numPlaces() {
  const char* env = std::getenv("EVERMAP_BOW_PLACES");
  return env && *env ? static_cast<size_t>(std::atol(env)) : 10000;
}

std::vector<Descriptor> perturb(const std::vector<Descriptor>& source,
                                const std::vector<std::vector<Descriptor>>& pool, SplitMix64& rng) {
  std::vector<Descriptor> out;
  out.reserve(source.size());
  for (const Descriptor& d : source) {
    if (rng.uniform() < 0.2) {
      const auto& other = pool[rng.below(pool.size())];
      if (!other.empty()) {
        out.push_back(other[rng.below(other.size())]);
        continue;
      }
    }
    Descriptor p = d;
    for (int bit = 0; bit < kDescriptorBits; ++bit) {
      if (rng.uniform() < 0.05) p.bytes[bit >> 3] ^= static_cast<uint8_t>(1u << (bit & 7));
    }
    out.push_back(p);
  }
  return out;
}

struct Setup {
  std::optional<Vocabulary> vocabulary;
  std::vector<std::vector<Descriptor>> real;         // per real image
  std::vector<std::vector<Descriptor>> place_descs;  // per synthetic place
  std::vector<BowVector> place_bows;
  std::vector<BowVector> queries;                // revisits
  std::vector<int64_t> query_truth;              // the place each query revisits
  double postings_per_query = 0;                 // mean postings a query reads, one floor
  std::optional<PlaceDatabase> database;         // 10,000 places, one floor
  std::optional<PlaceDatabase> database_floors;  // the same places over 10 floors
};

const Setup& setup() {
  static Setup s = [] {
    Setup r;
    const auto t0 = Clock::now();
    ImageTrainingSummary summary;
    auto folders = defaultTrainingFolders(dataRoot());
    if (folders.empty()) {
      std::fprintf(stderr, "bow_bench: no shared images under %s (set EVERMAP_DATA)\n",
                   dataRoot().c_str());
      std::exit(1);
    }
    auto v = trainFromImageFolders(folders, {}, &summary);
    if (!v) {
      std::fprintf(stderr, "bow_bench: %s\n", v.error().message.c_str());
      std::exit(1);
    }
    r.vocabulary = std::move(*v);
    std::fprintf(stderr, "bow_bench: vocabulary %s\n", summary.message.c_str());
    auto pool_folders = folders;
    const fs::path samples = dataRoot() / "rtabmap-lcd-samples" / "samples";
    if (fs::is_directory(samples)) pool_folders.push_back(samples);
    for (const auto& folder : pool_folders) {
      // (Named first: a range-for over listImages(folder).value() would dangle.)
      const std::vector<fs::path> files = listImages(folder).value();
      for (const auto& file : files) {
        r.real.push_back(extractOrbFromFile(file, {}).value().descriptors);
      }
    }
    SplitMix64 rng(2024);
    const size_t n = numPlaces();
    PlaceDatabase one(r.vocabulary->numWords(), r.vocabulary->fingerprint());
    PlaceDatabase ten(r.vocabulary->numWords(), r.vocabulary->fingerprint());
    for (size_t p = 0; p < n; ++p) {
      r.place_descs.push_back(perturb(r.real[rng.below(r.real.size())], r.real, rng));
      r.place_bows.push_back(r.vocabulary->transform(r.place_descs.back()));
      (void)one.insert({static_cast<int64_t>(p), 0, static_cast<int64_t>(p), r.place_bows.back()});
      (void)ten.insert({static_cast<int64_t>(p), static_cast<int32_t>(p % 10),
                        static_cast<int64_t>(p), r.place_bows.back()});
    }
    for (int q = 0; q < 500; ++q) {
      const size_t p = rng.below(n);
      r.queries.push_back(r.vocabulary->transform(perturb(r.place_descs[p], r.real, rng)));
      r.query_truth.push_back(static_cast<int64_t>(p));
    }
    std::fprintf(stderr,
                 "bow_bench: %zu real images, %zu places (%zu postings, %.1f MB of postings), "
                 "set up in %.0f s\n",
                 r.real.size(), n, one.numPostings(), one.numPostings() * 8.0 / 1e6,
                 std::chrono::duration<double>(Clock::now() - t0).count());
    std::vector<uint32_t> list_length(r.vocabulary->numWords(), 0);
    for (const BowVector& b : r.place_bows) {
      for (const WordWeight& e : b) ++list_length[e.word];
    }
    for (const BowVector& b : r.queries) {
      for (const WordWeight& e : b) r.postings_per_query += list_length[e.word];
    }
    r.postings_per_query /= static_cast<double>(r.queries.size());
    r.database = std::move(one);
    r.database_floors = std::move(ten);
    return r;
  }();
  return s;
}

// Wall-clock and CPU times of individually timed calls.
struct Timings {
  std::vector<double> wall_us, cpu_us;
  template <typename F>
  void time(F&& f) {
    const double c0 = 1e6 * threadCpuSeconds();
    const auto t0 = Clock::now();
    f();
    wall_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    cpu_us.push_back(1e6 * threadCpuSeconds() - c0);
  }
  void report(benchmark::State& state) {
    if (wall_us.empty()) return;
    for (auto* v : {&wall_us, &cpu_us}) std::sort(v->begin(), v->end());
    const size_t p99 = std::min(wall_us.size() - 1, wall_us.size() * 99 / 100);
    state.counters["median_us"] = wall_us[wall_us.size() / 2];
    state.counters["p99_us"] = wall_us[p99];
    state.counters["cpu_median_us"] = cpu_us[cpu_us.size() / 2];
    state.counters["cpu_p99_us"] = cpu_us[p99];
  }
};

// One query against every place (a global search on a single floor), top 10.
void BM_QueryAllPlaces(benchmark::State& state, bool ten_floors) {
  const Setup& s = setup();
  const PlaceDatabase& db = ten_floors ? *s.database_floors : *s.database;
  PlaceQuery q;
  q.top_k = 10;
  Timings timings;
  size_t k = 0, first = 0, asked = 0;
  for (auto _ : state) {
    const size_t i = k++ % s.queries.size();
    if (ten_floors) q.floor = static_cast<int32_t>(s.query_truth[i] % 10);
    Expected<std::vector<PlaceMatch>> r = std::vector<PlaceMatch>{};
    timings.time([&] { r = db.query(s.queries[i], q); });
    benchmark::DoNotOptimize(r);
    ++asked;
    first += (!r->empty() && (*r)[0].id == s.query_truth[i]) ? 1 : 0;
  }
  timings.report(state);
  state.counters["places"] = static_cast<double>(db.size());
  state.counters["top1_is_source"] = static_cast<double>(first) / std::max<size_t>(asked, 1);
  if (!ten_floors) state.counters["postings_read"] = s.postings_per_query;
}

// Building the database place by place; each insertion timed.
void BM_Insert(benchmark::State& state) {
  const Setup& s = setup();
  Timings timings;
  for (auto _ : state) {
    PlaceDatabase db(s.vocabulary->numWords(), s.vocabulary->fingerprint());
    for (size_t p = 0; p < s.place_bows.size(); ++p) {
      Place place{static_cast<int64_t>(p), 0, static_cast<int64_t>(p), s.place_bows[p]};
      timings.time([&] { benchmark::DoNotOptimize(db.insert(std::move(place))); });
    }
  }
  timings.report(state);
  state.counters["places"] = static_cast<double>(s.place_bows.size());
}

// Quantising one image's 1000 descriptors into a BoW vector and a direct index.
void BM_Transform(benchmark::State& state) {
  const Setup& s = setup();
  Timings timings;
  size_t k = 0;
  BowVector bow;
  FeatureVector direct;
  for (auto _ : state) {
    const auto& d = s.real[k++ % s.real.size()];
    timings.time([&] { s.vocabulary->transform(d, 2, &bow, &direct); });
    benchmark::DoNotOptimize(bow);
  }
  timings.report(state);
}

}  // namespace

BENCHMARK_CAPTURE(BM_QueryAllPlaces, one_floor, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_QueryAllPlaces, one_of_ten_floors, true)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Insert)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_Transform)->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
