// libFuzzer target: `pvcap recover`, `pvcap verify` and `pvcap compact` on damaged stores. Each input is a damage
// script applied to a copy of a small real store in the default raw video (make_store_seeds:
// raw-interrupted, its writer killed mid-recording, or raw-finished): files cut short, removed,
// bytes changed at chosen places. Then recover, verify and the reader run on it, as a lab would
// after a crash. Whatever the damage:
//   - no crash, hang or exception; every error is a message;
//   - recover that succeeds leaves a store a second recover does not change (every file's bytes);
//   - a store verify calls clean opens in the reader, and every sample reads;
//   - compact on any of them ends in a message or a store; a clean store stays clean.
#include <fuzzer/FuzzedDataProvider.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "storage/index/session_reader.h"
#include "storage/tools/compact.h"
#include "storage/tools/verify.h"
#include "storage/writer/recover.h"
#include "tests/fuzz/fuzz_scratch.h"

#define PVCAP_STRINGIFY2(x) #x
#define PVCAP_STRINGIFY(x) PVCAP_STRINGIFY2(x)

namespace fs = std::filesystem;

namespace {

const std::filesystem::path& scratch() { return pvcap::fuzz::scratch("damage"); }

using Files = std::map<std::string, std::string>;  // name -> bytes

Files read_folder(const fs::path& dir) {
  Files files;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::ifstream in(e.path(), std::ios::binary);
    files[e.path().filename().string()] = std::string(std::istreambuf_iterator<char>(in), {});
  }
  return files;
}

// The baselines, read once (made by make_store_seeds into the build tree).
const std::vector<Files>& baselines() {
  static const std::vector<Files> b = [] {
    const fs::path from = PVCAP_STRINGIFY(PVCAP_STORE_BASELINES);
    std::vector<Files> out;
    for (const char* name : {"raw-interrupted", "raw-finished"}) {
      if (!fs::is_directory(from / name)) {
        std::fprintf(stderr, "fuzz_store_damage: %s is missing: run make_store_seeds %s first\n", (from / name).c_str(),
                     from.c_str());
        std::exit(2);
      }
      out.push_back(read_folder(from / name));
    }
    return out;
  }();
  return b;
}

void write_folder(const fs::path& dir, const Files& files) {
  std::error_code ec;
  fs::remove_all(dir, ec);
  fs::create_directories(dir);
  for (const auto& [name, bytes] : files)
    std::ofstream(dir / name, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

void damage(FuzzedDataProvider& in, Files& files) {
  std::vector<std::string> names;
  for (const auto& [name, bytes] : files) names.push_back(name);
  const int steps = in.ConsumeIntegralInRange<int>(0, 8);
  for (int i = 0; i < steps && !names.empty(); ++i) {
    const std::string& name = names[in.ConsumeIntegralInRange<std::size_t>(0, names.size() - 1)];
    std::string& bytes = files[name];
    switch (in.ConsumeIntegralInRange<int>(0, 5)) {
      case 0:  // cut short (a power cut, a full disk)
        bytes.resize(in.ConsumeIntegralInRange<std::size_t>(0, bytes.size()));
        break;
      case 1:  // gone
        files.erase(name);
        names.erase(std::find(names.begin(), names.end(), name));
        break;
      case 2: {  // a run of bytes overwritten
        if (bytes.empty()) break;
        const std::size_t at = in.ConsumeIntegralInRange<std::size_t>(0, bytes.size() - 1);
        const std::string with = in.ConsumeBytesAsString(in.ConsumeIntegralInRange<std::size_t>(1, 16));
        for (std::size_t k = 0; k < with.size() && at + k < bytes.size(); ++k) bytes[at + k] = with[k];
        break;
      }
      case 3: {  // a zeroed page (a torn write)
        if (bytes.empty()) break;
        const std::size_t at = in.ConsumeIntegralInRange<std::size_t>(0, bytes.size() - 1) & ~std::size_t(4095);
        for (std::size_t k = at; k < at + 4096 && k < bytes.size(); ++k) bytes[k] = 0;
        break;
      }
      default: {  // one bit flipped
        if (bytes.empty()) break;
        const std::size_t at = in.ConsumeIntegralInRange<std::size_t>(0, bytes.size() - 1);
        bytes[at] = char(bytes[at] ^ (1 << in.ConsumeIntegralInRange<int>(0, 7)));
      }
    }
  }
}

void read_all(const fs::path& dir) {
  auto r = pvcap::SessionReader::open(dir);
  if (!r) __builtin_trap();  // verify called it clean
  auto& reader = *r.value();
  for (std::size_t i = 0; i < reader.sample_count(); ++i)
    if (!reader.sample(i, pvcap::PressureMode::Nearest)) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  const auto& bases = baselines();
  Files files = bases[in.ConsumeBool() ? 1 : 0];
  damage(in, files);
  const fs::path dir = scratch() / "session";
  write_folder(dir, files);

  auto recovered = pvcap::recover_session(dir);
  if (recovered) {
    // Recovered once, a second time changes nothing.
    const Files after = read_folder(dir);
    auto again = pvcap::recover_session(dir);
    if (!again) __builtin_trap();
    if (read_folder(dir) != after) __builtin_trap();
  } else if (recovered.error().message.empty()) {
    __builtin_trap();
  }
  const auto report = pvcap::verify_session(dir);
  for (const auto* list : {&report.facts, &report.losses, &report.errors})
    for (const auto& line : *list)
      if (line.empty()) __builtin_trap();
  if (report.exit_code() == 0) read_all(dir);
  pvcap::CompactOptions one_thread;
  one_thread.threads = 1;
  auto compacted = pvcap::compact_session(dir, one_thread);
  if (!compacted && compacted.error().message.empty()) __builtin_trap();
  // A clean store stays clean, compacted or not (compact may refuse an index damaged where verify
  // does not look, e.g. a table it writes to: with a message, and nothing changed).
  if (report.exit_code() == 0) {
    if (pvcap::verify_session(dir).exit_code() != 0) __builtin_trap();
    read_all(dir);
  }
  return 0;
}
