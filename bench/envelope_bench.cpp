// The envelope's cost per message (core/messages/envelope.h, issue 47): sealing (trailer +
// keyed BLAKE2b-256) at the sender, opening and checking the MAC at the receiver, without a
// key (identity only) and with one, for the sizes of an IMU sample, a VO_DELTA and a stereo
// frame (EuRoC, 2 x 752 x 480 raw 8-bit). Figures: docs/results/reliability.md.
#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <evermap/imu_t.hpp>
#include <evermap/vo_delta_t.hpp>

#include "core/messages/envelope.h"

namespace {

using evermap::messages::Envelope;
using evermap::messages::MacKey;

int64_t sizeOf(int which) {
  if (which == 0) return evermap::imu_t{}.getEncodedSize();
  if (which == 1) return evermap::vo_delta_t{}.getEncodedSize();
  return 2 * 752 * 480 + 200;
}

const char* nameOf(int which) { return which == 0 ? "IMU" : which == 1 ? "VO_DELTA" : "STEREO"; }

MacKey benchKey() {
  std::array<uint8_t, MacKey::kBytes> b;
  for (size_t k = 0; k < b.size(); ++k) b[k] = static_cast<uint8_t>(k * 7 + 1);
  return MacKey::fromBytes(b);
}

void BM_Seal(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const bool keyed = state.range(1) != 0;
  const MacKey key = benchKey();
  const std::vector<uint8_t> message(static_cast<size_t>(sizeOf(which)), 0x5a);
  Envelope e{{"evermap-vo-proc", 0x1234}, 0, 1'800'000'000'000'000, keyed};
  std::vector<uint8_t> bytes;
  for (auto _ : state) {
    bytes = message;
    ++e.counter;
    evermap::messages::appendEnvelope(nameOf(which), e, keyed ? &key : nullptr, bytes);
    benchmark::DoNotOptimize(bytes.data());
  }
  state.SetLabel(std::string(nameOf(which)) + " " + std::to_string(message.size()) + " B" +
                 (keyed ? ", key" : ", no key") + " (includes the copy of the message)");
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(message.size()));
}
BENCHMARK(BM_Seal)->ArgsProduct({{0, 1, 2}, {0, 1}})->Unit(benchmark::kMicrosecond);

void BM_OpenAndVerify(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const bool keyed = state.range(1) != 0;
  const MacKey key = benchKey();
  std::vector<uint8_t> bytes(static_cast<size_t>(sizeOf(which)), 0x5a);
  evermap::messages::appendEnvelope(nameOf(which),
                                    Envelope{{"evermap-vo-proc", 0x1234}, 1, 0, keyed},
                                    keyed ? &key : nullptr, bytes);
  for (auto _ : state) {
    auto opened = evermap::messages::openEnvelope(
        nameOf(which), bytes.data(), static_cast<int64_t>(bytes.size()), keyed ? &key : nullptr);
    if (!opened || (keyed && !opened->mac_valid)) state.SkipWithError("the envelope did not open");
    benchmark::DoNotOptimize(opened);
  }
  state.SetLabel(std::string(nameOf(which)) + (keyed ? ", key" : ", no key"));
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(bytes.size()));
}
BENCHMARK(BM_OpenAndVerify)->ArgsProduct({{0, 1, 2}, {0, 1}})->Unit(benchmark::kMicrosecond);

}  // namespace
BENCHMARK_MAIN();
