#include "core/time.h"

#include <ctime>

#include <fmt/format.h>

namespace pvcap {

HostNs host_now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return HostNs{std::int64_t(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec};
}

std::int64_t wall_now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return std::int64_t(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

static double cpu_seconds(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return double(ts.tv_sec) + double(ts.tv_nsec) * 1e-9;
}

double thread_cpu_seconds() { return cpu_seconds(CLOCK_THREAD_CPUTIME_ID); }
double process_cpu_seconds() { return cpu_seconds(CLOCK_PROCESS_CPUTIME_ID); }

static std::tm utc_tm(std::int64_t wall_ns) {
  std::time_t secs = wall_ns / 1'000'000'000;
  std::tm tm{};
  gmtime_r(&secs, &tm);
  return tm;
}

std::string format_utc(std::int64_t wall_ns) {
  const std::tm tm = utc_tm(wall_ns);
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:03}Z", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
                     tm.tm_hour, tm.tm_min, tm.tm_sec, (wall_ns / 1'000'000) % 1000);
}

std::string format_utc_compact(std::int64_t wall_ns) {
  const std::tm tm = utc_tm(wall_ns);
  return fmt::format("{:04}{:02}{:02}-{:02}{:02}{:02}", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour,
                     tm.tm_min, tm.tm_sec);
}

}  // namespace pvcap
