#include "codec/sensel_capture_file.h"

#include <algorithm>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "codec/sensel_frame.h"
#include "codec/sensel_units.h"
#include "core/sequence_unwrap.h"

namespace pvcap::sensel {

namespace {

Result<std::vector<std::uint8_t>> from_hex(const std::string& hex) {
  if (hex.size() % 2) return Error{"odd number of hex digits"};
  std::vector<std::uint8_t> out(hex.size() / 2);
  for (std::size_t i = 0; i < out.size(); ++i) {
    unsigned v = 0;
    for (int k = 0; k < 2; ++k) {
      const char c = hex[2 * i + std::size_t(k)];
      v <<= 4;
      if (c >= '0' && c <= '9')
        v |= unsigned(c - '0');
      else if (c >= 'a' && c <= 'f')
        v |= unsigned(c - 'a' + 10);
      else if (c >= 'A' && c <= 'F')
        v |= unsigned(c - 'A' + 10);
      else
        return Error{fmt::format("'{}' is not a hex digit", c)};
    }
    out[i] = std::uint8_t(v);
  }
  return out;
}

Status read_metadata(const nlohmann::json& header, CaptureFile& file) {
  const auto it = header.find("compression_metadata");
  if (it == header.end() || !it->is_object() || !it->contains("data_hex") || !(*it)["data_hex"].is_string())
    return Error{"no compression_metadata.data_hex (register 0x1C): the grid is unknown"};
  auto bytes = from_hex((*it)["data_hex"].get<std::string>());
  if (!bytes) return Error{"compression_metadata.data_hex: " + bytes.error().message};
  file.metadata = std::move(bytes.value());
  return {};
}

Status read_frame(const nlohmann::json& j, std::size_t line, CaptureFile& file) {
  if (!j.is_object() || !j.contains("payload_hex") || !j["payload_hex"].is_string())
    return Error{"frame without payload_hex"};
  auto bytes = from_hex(j["payload_hex"].get<std::string>());
  if (!bytes) return Error{"payload_hex: " + bytes.error().message};
  CapturedFrame f{line, std::move(bytes.value()), -1};
  if (j.contains("checksum") && j["checksum"].is_number_integer()) f.checksum = j["checksum"].get<int>();
  file.frames.push_back(std::move(f));
  return {};
}

}  // namespace

Result<CaptureFile> load_capture_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) return Error{fmt::format("{}: cannot open", path.string())};
  CaptureFile file;
  file.path = path;
  try {
    if (path.extension() == ".jsonl") {
      std::string line;
      std::size_t n = 0;
      bool have_header = false;
      while (std::getline(in, line)) {
        ++n;
        if (line.empty()) continue;
        const auto j = nlohmann::json::parse(line);
        const std::string type = j.value("type", "");
        Status s;
        if (type == "header") {
          s = read_metadata(j, file);
          have_header = true;
        } else if (type == "frame") {
          s = read_frame(j, n, file);
        }  // other line types are not ours to judge
        if (!s.ok()) return Error{fmt::format("{}:{}: {}", path.string(), n, s.error().message)};
      }
      if (!have_header) return Error{fmt::format("{}: no header line", path.string())};
    } else {
      const auto j = nlohmann::json::parse(in);
      if (Status s = read_metadata(j, file); !s.ok())
        return Error{fmt::format("{}: {}", path.string(), s.error().message)};
      if (!j.contains("frames") || !j["frames"].is_array())
        return Error{fmt::format("{}: no frames array", path.string())};
      for (std::size_t i = 0; i < j["frames"].size(); ++i)
        if (Status s = read_frame(j["frames"][i], i, file); !s.ok())
          return Error{fmt::format("{}: frames[{}]: {}", path.string(), i, s.error().message)};
    }
  } catch (const nlohmann::json::exception& e) {
    return Error{fmt::format("{}: not valid JSON: {}", path.string(), e.what())};
  }
  return file;
}

Result<CaptureSummary> summarise_capture_file(const std::filesystem::path& path) {
  auto file = load_capture_file(path);
  if (!file) return file.error();
  auto grid = grid_from_metadata(file.value().metadata);
  if (!grid) return Error{fmt::format("{}: {}", path.string(), grid.error().message)};
  CaptureSummary s;
  s.grid = grid.value();
  SequenceUnwrapper counter(8, /*zero_is_skipped=*/false);
  SequenceUnwrapper clock(32, false);  // µs timestamps wrap every ~71.6 min
  std::uint64_t first_us = 0, last_us = 0;
  auto reject = [&](const CapturedFrame& cf, const std::string& why) {
    ++s.rejected[why];
    if (s.first_rejection.empty()) s.first_rejection = fmt::format("frame at {}: {}", cf.line, why);
  };
  for (const auto& cf : file.value().frames) {
    ++s.frames;
    if (cf.checksum >= 0 && checksum(cf.payload) != cf.checksum) {
      reject(cf, "checksum mismatch");
      continue;
    }
    auto f = parse_frame(cf.payload, s.grid);
    if (!f) {
      reject(cf, f.error().message);
      continue;
    }
    ++s.decoded;
    s.counter_gaps += counter.next(f.value().counter).missing;
    const std::uint64_t t = clock.next(f.value().timestamp_us).sequence;
    if (s.decoded == 1) first_us = t;
    last_us = t;
    if (f.value().pressure) {
      double total = 0;
      for (std::uint16_t c : f.value().pressure->counts) {
        const double g = counts_to_grams(c);
        total += g;
        if (g > s.peak_cell_g) {
          s.peak_cell_g = g;
          s.peak_cell_kpa = native_cell_kpa(c, s.grid);
        }
      }
      s.peak_total_g = std::max(s.peak_total_g, total);
    }
  }
  s.span_s = double(last_us - first_us) / 1e6;
  return s;
}

}  // namespace pvcap::sensel
