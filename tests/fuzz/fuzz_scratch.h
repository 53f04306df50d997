// A fuzz target's scratch folder for the files it writes each input to: <tmp>/pvcap-fuzz-<name>-<pid>,
// made on first use and removed when the process exits (libFuzzer ends with exit(), which runs
// static destructors), so a run leaves nothing under /tmp.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace pvcap::fuzz {

inline const std::filesystem::path& scratch(const char* name) {
  struct Folder {
    std::filesystem::path dir;
    explicit Folder(const char* name)
        : dir(std::filesystem::temp_directory_path() /
              ("pvcap-fuzz-" + std::string(name) + "-" + std::to_string(getpid()))) {
      std::filesystem::create_directories(dir);
    }
    ~Folder() {
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    }
  };
  static const Folder folder(name);
  return folder.dir;
}

}  // namespace pvcap::fuzz
