#pragma once
// A scratch folder for a unit test: made empty, removed when the test ends, also when an
// assertion ends it early.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace pvcap::testing {

struct TempDir {
  std::filesystem::path path;
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

// An empty folder /tmp/pvcap-test-<kind>-<name>-<pid>.
inline std::filesystem::path fresh_temp_dir(const std::string& kind, const std::string& name) {
  const auto d =
      std::filesystem::temp_directory_path() / ("pvcap-test-" + kind + "-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

}  // namespace pvcap::testing
