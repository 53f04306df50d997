// `pvcap sensel decode` on the real captures, and on damaged copies of them.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "session_under_test.h"

namespace fs = std::filesystem;
using pvcap::testing::run_pvcap;
using pvcap::testing::work_dir;

namespace {
const fs::path kCaptures = fs::path(PVCAP_SOURCE_DIR) / ".." / "shared" / "data" / "sensel-captures";

}  // namespace

TEST(SenselDecode, RealCapturesDecodeAndTheSummaryIsPrinted) {
  const auto r = run_pvcap("sensel decode " + (kCaptures / "sensel_recording_20260712_021955.jsonl").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("757 decoded of 757"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("93x53 native"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("1 frames missing by the rolling counter"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("kPa"), std::string::npos) << r.output;
}

TEST(SenselDecode, ACorruptedFrameFailsTheRunAndSaysWhy) {
  const auto dir = work_dir("sensel-corrupt");
  std::ifstream in(kCaptures / "sensel_recording_20260712_000721.jsonl");
  std::ofstream out(dir / "bad.jsonl");
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    if (++n == 5) {  // truncate one frame's payload (and fix nothing else)
      const auto at = line.find("\"payload_hex\":\"");
      line.erase(at + 15 + 20, 6);
    }
    out << line << '\n';
  }
  out.close();
  const auto r = run_pvcap("sensel decode " + (dir / "bad.jsonl").string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("303 decoded of 304"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("FAILED: 1 frames could not be decoded (first: frame at 5:"), std::string::npos) << r.output;
}

TEST(SenselDecode, AForeignFileIsNamedInOneMessage) {
  const auto dir = work_dir("sensel-foreign");
  std::ofstream(dir / "x.json") << "{\"hello\": 1}";
  const auto r = run_pvcap("sensel decode " + (dir / "x.json").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("x.json: no compression_metadata"), std::string::npos) << r.output;
}
