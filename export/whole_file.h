#pragma once
// Files the export writes are whole or absent: written beside their final name and renamed over it,
// so readers and a resumed run never see a half-written one.
#include <filesystem>
#include <string>

#include "core/result.h"

namespace pvcap::exporting {

Status write_atomically(const std::filesystem::path& path, const std::string& bytes);

}  // namespace pvcap::exporting
