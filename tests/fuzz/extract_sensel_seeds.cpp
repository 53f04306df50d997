// Writes the payloads of the real captures (read in place from ../shared) as fuzz seeds, one file
// per distinct frame size, prefixed with the grid byte the fuzz target expects (1 = high detail).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

#include "codec/sensel_capture_file.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: extract_sensel_seeds CAPTURE_DIR OUT_DIR\n");
    return 2;
  }
  namespace fs = std::filesystem;
  if (!fs::is_directory(argv[1])) {
    std::fprintf(stderr,
                 "extract_sensel_seeds: %s is not a folder: the real Sensel captures are read from "
                 "../shared beside the repository\n",
                 argv[1]);
    return 1;
  }
  fs::create_directories(argv[2]);
  int written = 0;
  for (const auto& e : fs::directory_iterator(argv[1])) {
    if (e.path().extension() != ".json" && e.path().extension() != ".jsonl") continue;
    auto file = pvcap::sensel::load_capture_file(e.path());
    if (!file) {
      std::fprintf(stderr, "%s\n", file.error().message.c_str());
      return 1;
    }
    std::set<std::size_t> sizes;
    for (const auto& f : file.value().frames) {
      if (!sizes.insert(f.payload.size() / 64).second) continue;  // a spread of sizes is enough
      std::ofstream out(fs::path(argv[2]) / (e.path().stem().string() + "_" + std::to_string(f.line)),
                        std::ios::binary);
      const char grid = file.value().metadata.size() == 6 && file.value().metadata[2] == 93 ? 1 : 0;
      out.put(grid);
      out.write(reinterpret_cast<const char*>(f.payload.data()), std::streamsize(f.payload.size()));
      ++written;
    }
  }
  std::printf("%d seeds\n", written);
  return written > 0 ? 0 : 1;
}
