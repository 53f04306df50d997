// A read the disk fails under the two commands that read a whole finished session and write
// something of their own (issue 58, item 3): `pvcap export` and `pvcap compact`, on the export
// tests' recorded protocol session. The failing read is drawn (seed printed, PVCAP_TEST_SEED
// repeats a run) among the command's own reads of the session (tests/io_faults/io_faults.c). Each such run ends in exit
// 1 with an ERROR line naming the file, or, where FFmpeg retried the read or did not need it, does its whole work as on
// a good day; and the next run without the fault finishes the same work: the export resumes to the same files, the
// session compacts and verifies as before.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "tests/integration/export_fixture.h"
#include "tests/integration/session_under_test.h"

namespace fs = std::filesystem;
using namespace pvcap::testing;

namespace {

unsigned read_failure_seed() {
  const char* given = std::getenv("PVCAP_TEST_SEED");
  const unsigned seed = given ? unsigned(std::strtoul(given, nullptr, 10)) : std::random_device{}();
  std::printf("seed %u (PVCAP_TEST_SEED=%u repeats this run)\n", seed, seed);
  return seed;
}

// `pvcap ARGS` with the session's `fault` armed (reads of files under `root` only).
CommandResult with_read_fault(const std::string& fault, const fs::path& root, const std::string& args,
                              const fs::path& count = {}) {
  std::string env = fmt::format("env LD_PRELOAD={} PVCAP_IO_FAULT={} PVCAP_IO_FAULT_ROOT={}", PVCAP_IO_FAULTS_LIB,
                                fault, root.string());
  if (!count.empty()) env += " PVCAP_IO_FAULT_COUNT=" + count.string();
  return run_pvcap(args, env);
}

// How many reads of the session `args` makes on a good day (it must succeed).
long count_reads(const fs::path& root, const std::string& args, const fs::path& count) {
  const auto r = with_read_fault("session:read:0:count", root, args, count);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  long reads = 0;
  std::ifstream in(count);
  std::string op;
  for (long n = 0; in >> op >> n;)
    if (op == "read") reads = std::max(reads, n);
  fs::remove(count);
  return reads;
}

// The file the injected failure hit ("" when the drawn read never came: a run that read less). A read
// of the index's write-ahead log or shared memory is the index's: SQLite reports it as the index's I/O
// error, and pvcap names the index (session.db), the file a user knows.
std::string failed_file(const std::string& output) {
  static const std::regex failed_call(R"(io_faults: read #\d+ of (\S+) failed with EIO)");
  std::smatch m;
  if (!std::regex_search(output, m, failed_call)) return "";
  std::string file = fs::path(m[1].str()).filename().string();
  for (const char* part : {"-wal", "-shm"})
    if (file.size() > 4 && file.ends_with(part)) file.resize(file.size() - 4);
  return file;
}

// An error line of pvcap's log ("[time error] ...") or of a verdict ("ERROR ...") that names `file`
// (the injector's own line, "io_faults: ...", is neither).
bool an_error_line_names(const std::string& output, const std::string& file) {
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);)
    if ((line.find(" error] ") != std::string::npos || line.find("ERROR") != std::string::npos) &&
        line.find(file) != std::string::npos)
      return true;
  return false;
}

}  // namespace

TEST(Export, AReadTheDiskFailsIsNamedAndTheNextRunFinishesTheSameExport) {
  std::mt19937 rng(read_failure_seed());
  const Recorded& rec = recorded();
  ASSERT_FALSE(rec.session.empty());
  const fs::path work = work_dir("export-read-fails");
  const std::string layout = "--log-level warn export " + rec.session.string() + " --layout pressurevision --out ";
  const long reads = count_reads(rec.session, layout + (work / "good").string(), work / "count.txt");
  ASSERT_GT(reads, 50) << "export reads the index and every video";
  const auto good = folder_hashes(work / "good");
  for (int k = 0; k < 2; ++k) {
    const long n = std::uniform_int_distribution<long>(1, reads)(rng);
    SCOPED_TRACE(fmt::format("export, read #{} of {}", n, reads));
    const fs::path out = work / fmt::format("out-{}", k);
    const auto r = with_read_fault(fmt::format("session:read:{}:eio-once", n), rec.session, layout + out.string());
    const std::string file = failed_file(r.output);
    if (r.exit_code == 0) {
      // FFmpeg retried the read or never needed it: every frame was still exported.
      EXPECT_EQ(folder_hashes(out), good) << r.output;
      std::printf("export with read #%ld of %s failed: exit 0, the same files as on a good day\n", n, file.c_str());
    } else {
      EXPECT_EQ(r.exit_code, 1) << r.output;
      EXPECT_FALSE(file.empty()) << r.output;
      EXPECT_TRUE(an_error_line_names(r.output, file)) << "no ERROR line names " << file << ":\n" << r.output;
      std::printf("export with read #%ld of %s failed: exit 1, named\n", n, file.c_str());
    }
    const auto resumed = run_pvcap(layout + out.string());
    ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
    EXPECT_EQ(folder_hashes(out), good) << "the run after the failure finishes the same export";
    fs::remove_all(out);
  }
}

TEST(StoreCompact, AReadTheDiskFailsIsNamedAndTheSessionStaysAsItWas) {
  std::mt19937 rng(read_failure_seed());
  const Recorded& rec = recorded();
  ASSERT_FALSE(rec.session.empty());
  const fs::path work = work_dir("compact-read-fails");
  const fs::path dir = work / "session";
  ASSERT_EQ(std::system(fmt::format("cp -a {} {}", rec.session.string(), dir.string()).c_str()), 0);
  const auto verdict = [](const fs::path& d) {
    const auto v = run_pvcap("--log-level off verify " + d.string());
    EXPECT_EQ(v.output.find("ERROR"), std::string::npos) << v.output;
    return std::to_string(v.exit_code) + " " + v.output.substr(std::min(v.output.size(), v.output.rfind("verdict")));
  };
  const std::string before = verdict(dir);
  const std::string compact = "--log-level warn compact --threads 2 " + dir.string();
  // Not counted first (a whole compact of this session takes 10 s here): one of the index's first
  // reads, then one of the videos' (compact reads each segment, ~28 MB, in some 900 reads, then its
  // new copy back: the draw falls inside the work), each where the last left off (a compact resumes).
  const std::pair<const char*, long> draws[] = {{"index", std::uniform_int_distribution<long>(1, 40)(rng)},
                                                {"segment", std::uniform_int_distribution<long>(1, 3000)(rng)}};
  for (const auto& [kind, n] : draws) {
    SCOPED_TRACE(fmt::format("compact, read #{} of a file of kind {}", n, kind));
    const auto r = with_read_fault(fmt::format("{}:read:{}:eio-once", kind, n), dir, compact);
    const std::string file = failed_file(r.output);
    if (r.exit_code != 0) {
      EXPECT_EQ(r.exit_code, 1) << r.output;
      EXPECT_FALSE(file.empty()) << r.output;
      EXPECT_TRUE(an_error_line_names(r.output, file)) << "no ERROR line names " << file << ":\n" << r.output;
    }
    std::printf("compact with read #%ld of %s failed: exit %d\n", n, file.empty() ? kind : file.c_str(), r.exit_code);
    // Every frame still there, as before: an old video is removed only once its new one read back bit exact.
    EXPECT_EQ(verdict(dir), before);
  }
  const auto last = run_pvcap(compact);
  EXPECT_EQ(last.exit_code, 0) << last.output;
  EXPECT_EQ(verdict(dir), before);
}
