#pragma once
// SHA-256 (FIPS 180-4) of bytes or a file, as lowercase hex: the export's manifest checksums,
// which `sha256sum` and Python's hashlib reproduce.
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/result.h"

namespace pvcap::exporting {

class Sha256 {
 public:
  // Fastest: the CPU's SHA instructions where it has them (x86 SHA-NI, ~5x the portable code),
  // otherwise Portable. Both give the same digest (tests hold them to each other).
  enum class Engine { Fastest, Portable };
  explicit Sha256(Engine engine = Engine::Fastest);
  void update(const void* data, std::size_t size);
  std::string hex();  // finishes; call once
  static bool cpu_has_sha_instructions();

 private:
  void blocks(const std::uint8_t* p, std::size_t count);
  std::uint32_t h_[8];
  bool hardware_ = false;
  std::uint8_t buffer_[64];
  std::size_t used_ = 0;
  std::uint64_t bytes_ = 0;
};

std::string sha256_hex(std::string_view bytes);
Result<std::string> sha256_file(const std::filesystem::path& path);

}  // namespace pvcap::exporting
