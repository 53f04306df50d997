// Sensel decode rate per core on the real captures (read in place from ../shared):
// parse (header, contacts, accelerometer) + pressure/label decode, and the same plus the
// 185 x 105 upsampling. One thread, so items/s is frames/s per core.
#include <benchmark/benchmark.h>

#include <filesystem>

#include "codec/sensel_capture_file.h"
#include "codec/sensel_frame.h"
#include "codec/sensel_units.h"

namespace {

struct Corpus {
  std::vector<std::vector<std::uint8_t>> payloads;
  pvcap::sensel::Grid grid;
};

const Corpus& corpus() {
  static const Corpus c = [] {
    Corpus c;
    const std::filesystem::path dir =
        std::filesystem::path(PVCAP_SOURCE_DIR) / ".." / "shared" / "data" / "sensel-captures";
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
      if (e.path().extension() != ".json" && e.path().extension() != ".jsonl") continue;
      auto f = pvcap::sensel::load_capture_file(e.path());
      if (!f) continue;
      c.grid = pvcap::sensel::grid_from_metadata(f.value().metadata).value();
      for (auto& fr : f.value().frames) c.payloads.push_back(fr.payload);
    }
    return c;
  }();
  return c;
}

void BM_ParseAndDecode(benchmark::State& state) {
  const Corpus& c = corpus();
  std::size_t i = 0;
  for (auto _ : state) {
    auto f = pvcap::sensel::parse_frame(c.payloads[i++ % c.payloads.size()], c.grid);
    benchmark::DoNotOptimize(f);
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()));
  state.counters["frames_in_corpus"] = double(c.payloads.size());
}

void BM_ParseDecodeUpsample(benchmark::State& state) {
  const Corpus& c = corpus();
  std::size_t i = 0;
  for (auto _ : state) {
    auto f = pvcap::sensel::parse_frame(c.payloads[i++ % c.payloads.size()], c.grid);
    if (f && f.value().pressure) {
      auto up = pvcap::sensel::upsample(f.value().pressure->counts, c.grid);
      benchmark::DoNotOptimize(up.data());
    }
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()));
}

}  // namespace

BENCHMARK(BM_ParseAndDecode);
BENCHMARK(BM_ParseDecodeUpsample);
BENCHMARK_MAIN();
