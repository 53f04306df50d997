#pragma once
// `pvcap export SESSION... --layout pressurevision|pressurevision-plus --out DIR [options]`: each
// session written in a released dataset layout (export/dataset_export.h), one after the other, with
// progress and the time left; an interrupted export resumes when run again.
#include <atomic>
#include <filesystem>
#include <vector>

#include "export/dataset_export.h"

namespace pvcap {

struct ExportCommand {
  std::vector<std::filesystem::path> sessions;
  exporting::ExportOptions options;
};

int cmd_export(const ExportCommand& c, const std::atomic<bool>& stop);

}  // namespace pvcap
