// An LD_PRELOAD interposer for tests: the n-th write, fsync, rename or read of one kind of the
// session's files fails as a dying disk makes it fail, so a real `pvcap` meets EIO, a full disk, a
// short write or a failed fsync through the code that runs on the rig. Set in the environment:
//   PVCAP_IO_FAULT="kind:op:n:what"
//     kind  segment (*.mkv), index (session.db), wal (session.db-wal), spill (*.spill), session
//           (any file under PVCAP_IO_FAULT_ROOT but the simulator's truth), or folder (a folder
//           there: its fsyncs, pvcap's and SQLite's own)
//     op    write (write, pwrite, writev, pwritev), fsync (fsync, fdatasync), rename (rename,
//           renameat, renameat2: either name of the kind) or read (read, pread, readv, preadv);
//           any, with what "count", counts each of them
//     n     the first call that fails (counted per process over files of that kind)
//     what  eio (that call and every later one fail with EIO), eio-once and enospc-once (that call
//           alone fails, with EIO or, for a write, ENOSPC), short (that one call writes half),
//           slowMS (that one fsync takes MS milliseconds longer: a disk that stalls, e.g. slow1500),
//           or count (nothing fails; at exit the process appends "<op> <calls>" to the file
//           PVCAP_IO_FAULT_COUNT: how many n there are to try)
// Unset: every call goes straight to libc. Test instrument only: nothing of pvcap links it.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <unistd.h>

#include "../preload_paths.h"

static int g_armed = -1;  // -1: not read yet
static char g_kind[16], g_op[16], g_what[16];
static const char* g_root;
static long g_n;
static long g_count;
static void say_failed(const char* path, int decision);

// With op "any" and what "count": each op's calls, counted apart.
static const char* const kOps[4] = {"write", "fsync", "rename", "read"};
static long g_counts[4];

static void say_count(void) {
  const char* file = getenv("PVCAP_IO_FAULT_COUNT");
  if (!file) return;
  FILE* f = fopen(file, "a");
  if (!f) return;
  if (strcmp(g_op, "any") == 0) {
    for (int i = 0; i < 4; ++i) fprintf(f, "%s %ld\n", kOps[i], __atomic_load_n(&g_counts[i], __ATOMIC_SEQ_CST));
  } else {
    fprintf(f, "%s %ld\n", g_op, __atomic_load_n(&g_count, __ATOMIC_SEQ_CST));
  }
  fclose(f);
}

static void arm(void) {
  if (g_armed >= 0) return;
  g_armed = 0;
  const char* spec = getenv("PVCAP_IO_FAULT");
  if (!spec || sscanf(spec, "%15[^:]:%15[^:]:%ld:%15s", g_kind, g_op, &g_n, g_what) != 4) return;
  g_root = getenv("PVCAP_IO_FAULT_ROOT");
  g_armed = 1;
  if (strcmp(g_what, "count") == 0) atexit(say_count);
}

static int ends_with(const char* s, const char* tail) {
  const size_t a = strlen(s), b = strlen(tail);
  return a >= b && strcmp(s + a - b, tail) == 0;
}

static int path_of_kind(const char* path) {
  if (strcmp(g_kind, "segment") == 0) return ends_with(path, ".mkv");
  if (strcmp(g_kind, "index") == 0) return ends_with(path, "/session.db");
  if (strcmp(g_kind, "wal") == 0) return ends_with(path, "/session.db-wal");
  if (strcmp(g_kind, "spill") == 0) return ends_with(path, ".spill");
  const size_t n = g_root ? strlen(g_root) : 0;
  const int in_root = n > 0 && strncmp(path, g_root, n) == 0 && path[n] == '/' && !strstr(path, "sim-truth");
  if (strcmp(g_kind, "session") == 0) return in_root;
  if (strcmp(g_kind, "folder") == 0) {
    struct stat st;
    return in_root && stat(path, &st) == 0 && S_ISDIR(st.st_mode);
  }
  return 0;
}

// Whether `name` (relative to `dirfd`) is a file of the armed kind.
static int name_of_kind(int dirfd, const char* name) {
  char path[PATH_MAX];
  return preload_absolute_path(dirfd, name, path, sizeof path) && path_of_kind(path);
}

static long g_slow_ms;

// 0: pass the call on; 1: fail it with EIO; 2: write half of it; 3: pass it on g_slow_ms late;
// 4: fail it with ENOSPC. `matches` says whether the call is on a file of the armed kind.
static int decide_for(int matches, const char* op) {
  if (g_armed != 1 || !matches) return 0;
  if (strcmp(g_op, "any") == 0) {
    for (int i = 0; i < 4; ++i)
      if (strcmp(op, kOps[i]) == 0) __atomic_add_fetch(&g_counts[i], 1, __ATOMIC_SEQ_CST);
    return 0;
  }
  if (strcmp(g_op, op) != 0) return 0;
  const long k = __atomic_add_fetch(&g_count, 1, __ATOMIC_SEQ_CST);
  if (strcmp(g_what, "count") == 0 || k < g_n) return 0;
  if (strcmp(g_what, "eio-once") == 0) return k == g_n ? 1 : 0;
  if (strcmp(g_what, "enospc-once") == 0) return k == g_n ? 4 : 0;
  if (strcmp(g_what, "short") == 0) return k == g_n ? 2 : 0;
  if (strncmp(g_what, "slow", 4) == 0) {
    g_slow_ms = atol(g_what + 4);
    return k == g_n ? 3 : 0;
  }
  return 1;
}

static int decide(int fd, const char* op) {
  arm();
  if (g_armed != 1 || (strcmp(g_op, op) != 0 && strcmp(g_op, "any") != 0)) return 0;
  char link[64], path[4096];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  const ssize_t n = readlink(link, path, sizeof path - 1);
  if (n <= 0) return 0;
  path[n] = '\0';
  const int d = decide_for(path_of_kind(path), op);
  if (d == 1 || d == 4) say_failed(path, d);
  return d;
}

// The errno of a failing decision.
static int fail_with(int decision) {
  errno = decision == 4 ? ENOSPC : EIO;
  return -1;
}

// Says on stderr which call failed (a test matches the session's message against it).
static void say_failed(const char* path, int decision) {
  if (strstr(g_what, "once") == NULL) return;
  char line[4300];
  const int n = snprintf(line, sizeof line, "io_faults: %s #%ld of %s failed with %s\n", g_op, g_n, path,
                         decision == 4 ? "ENOSPC" : "EIO");
  if (n > 0) (void)!write(STDERR_FILENO, line, (size_t)n);
}

typedef ssize_t (*write_fn)(int, const void*, size_t);
typedef ssize_t (*pwrite_fn)(int, const void*, size_t, off_t);
typedef ssize_t (*writev_fn)(int, const struct iovec*, int);
typedef ssize_t (*pwritev_fn)(int, const struct iovec*, int, off_t);
typedef int (*sync_fn)(int);

// libc's own function of that name.
#define REAL(name, type)   \
  static type real_##name; \
  if (!real_##name) real_##name = (type)dlsym(RTLD_NEXT, #name)

ssize_t write(int fd, const void* buf, size_t count) {
  REAL(write, write_fn);
  const int d = decide(fd, "write");
  if (d == 1 || d == 4) return fail_with(d);
  return real_write(fd, buf, d == 2 && count > 1 ? count / 2 : count);
}

ssize_t pwrite64(int fd, const void* buf, size_t count, off_t offset) {
  REAL(pwrite64, pwrite_fn);
  const int d = decide(fd, "write");
  if (d == 1 || d == 4) return fail_with(d);
  return real_pwrite64(fd, buf, d == 2 && count > 1 ? count / 2 : count, offset);
}

ssize_t pwrite(int fd, const void* buf, size_t count, off_t offset) { return pwrite64(fd, buf, count, offset); }

ssize_t writev(int fd, const struct iovec* iov, int iovcnt) {
  REAL(writev, writev_fn);
  const int d = decide(fd, "write");
  if (d == 1 || d == 4) return fail_with(d);
  if (d == 2) return iovcnt > 0 ? real_writev(fd, iov, 1) : 0;  // the first part only: short
  return real_writev(fd, iov, iovcnt);
}

ssize_t pwritev64(int fd, const struct iovec* iov, int iovcnt, off_t offset) {
  REAL(pwritev64, pwritev_fn);
  const int d = decide(fd, "write");
  if (d == 1 || d == 4) return fail_with(d);
  if (d == 2) return iovcnt > 0 ? real_pwritev64(fd, iov, 1, offset) : 0;
  return real_pwritev64(fd, iov, iovcnt, offset);
}

ssize_t pwritev(int fd, const struct iovec* iov, int iovcnt, off_t offset) {
  return pwritev64(fd, iov, iovcnt, offset);
}

// Reads fail with EIO (a sector the disk cannot read); a full disk does not fail a read.
typedef ssize_t (*read_fn)(int, void*, size_t);
typedef ssize_t (*pread_fn)(int, void*, size_t, off_t);
typedef ssize_t (*readv_fn)(int, const struct iovec*, int);
typedef ssize_t (*preadv_fn)(int, const struct iovec*, int, off_t);

static int read_fails(int fd) {
  const int d = decide(fd, "read");
  return d == 1 || d == 4;
}

ssize_t read(int fd, void* buf, size_t count) {
  REAL(read, read_fn);
  if (read_fails(fd)) return fail_with(1);
  return real_read(fd, buf, count);
}

ssize_t pread64(int fd, void* buf, size_t count, off_t offset) {
  REAL(pread64, pread_fn);
  if (read_fails(fd)) return fail_with(1);
  return real_pread64(fd, buf, count, offset);
}

ssize_t pread(int fd, void* buf, size_t count, off_t offset) { return pread64(fd, buf, count, offset); }

ssize_t readv(int fd, const struct iovec* iov, int iovcnt) {
  REAL(readv, readv_fn);
  if (read_fails(fd)) return fail_with(1);
  return real_readv(fd, iov, iovcnt);
}

ssize_t preadv64(int fd, const struct iovec* iov, int iovcnt, off_t offset) {
  REAL(preadv64, preadv_fn);
  if (read_fails(fd)) return fail_with(1);
  return real_preadv64(fd, iov, iovcnt, offset);
}

ssize_t preadv(int fd, const struct iovec* iov, int iovcnt, off_t offset) { return preadv64(fd, iov, iovcnt, offset); }

// Renames fail with EIO (or ENOSPC: a new directory block), and nothing moves.
typedef int (*renameat2_fn)(int, const char*, int, const char*, unsigned);

int renameat2(int dirfd, const char* name, int dirfd2, const char* name2, unsigned flags) {
  REAL(renameat2, renameat2_fn);
  arm();
  if (g_armed == 1 && (strcmp(g_op, "rename") == 0 || strcmp(g_op, "any") == 0)) {
    const int d = decide_for(name_of_kind(dirfd, name) || name_of_kind(dirfd2, name2), "rename");
    if (d == 1 || d == 4) {
      say_failed(name2 ? name2 : name, d);
      return fail_with(d);
    }
  }
  return real_renameat2(dirfd, name, dirfd2, name2, flags);
}
int renameat(int dirfd, const char* name, int dirfd2, const char* name2) {
  return renameat2(dirfd, name, dirfd2, name2, 0);
}
int rename(const char* name, const char* name2) { return renameat2(AT_FDCWD, name, AT_FDCWD, name2, 0); }

// fsync and fdatasync fail alike.
static int failing_sync(int fd, sync_fn real) {
  switch (decide(fd, "fsync")) {
    case 1:
    case 4:
      return fail_with(1);
    case 3:
      usleep((useconds_t)(g_slow_ms * 1000));
      break;
  }
  return real(fd);
}

int fsync(int fd) {
  REAL(fsync, sync_fn);
  return failing_sync(fd, real_fsync);
}

int fdatasync(int fd) {
  REAL(fdatasync, sync_fn);
  return failing_sync(fd, real_fdatasync);
}
