// For the LD_PRELOAD test instruments (tests/io_faults/io_faults.c, tests/power_cut/io_trace.c): the
// absolute path a *at() call's (dirfd, name) names. Not resolved further: the tests' folders have no
// symbolic links. C, header only: each instrument is one translation unit of its own.
#ifndef PVCAP_TESTS_PRELOAD_PATHS_H
#define PVCAP_TESTS_PRELOAD_PATHS_H

#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <sys/types.h>
#include <unistd.h>

// 1 with the path in `out`; 0 when there is no name, its folder cannot be read, or the path does not
// fit (the tests' paths are short).
static inline int preload_absolute_path(int dirfd, const char* name, char* out, size_t size) {
  if (!name) return 0;
  if (name[0] == '/') return snprintf(out, size, "%s", name) < (int)size;
  char base[PATH_MAX];
  if (dirfd == AT_FDCWD) {
    if (!getcwd(base, sizeof base)) return 0;
  } else {
    char link[64];
    snprintf(link, sizeof link, "/proc/self/fd/%d", dirfd);
    const ssize_t n = readlink(link, base, sizeof base - 1);
    if (n <= 0) return 0;
    base[n] = '\0';
  }
  return snprintf(out, size, "%s/%s", base, name) < (int)size;
}

#endif
