// An LD_PRELOAD interposer for tests: the n-th write (or fsync) to one kind of the session's files
// fails as a dying disk makes it fail, so a real `pvcap session` meets EIO, a short write or a
// failed fsync through the code that runs on the rig. Set in the environment:
//   PVCAP_IO_FAULT="kind:op:n:what"
//     kind  segment (*.mkv), index (session.db), wal (session.db-wal), spill (*.spill)
//     op    write (write, pwrite, writev, pwritev) or fsync (fsync, fdatasync)
//     n     the first call that fails (counted per process over files of that kind)
//     what  eio (that call and every later one fail with EIO), short (that one call writes half) or
//           slowMS (that one fsync takes MS milliseconds longer: a disk that stalls, e.g. slow1500)
// Unset: every call goes straight to libc. Test instrument only: nothing of pvcap links it.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <unistd.h>

static int g_armed = -1;  // -1: not read yet
static char g_kind[16], g_op[16], g_what[16];
static long g_n;
static long g_count;

static void arm(void) {
  if (g_armed >= 0) return;
  g_armed = 0;
  const char* spec = getenv("PVCAP_IO_FAULT");
  if (!spec || sscanf(spec, "%15[^:]:%15[^:]:%ld:%15s", g_kind, g_op, &g_n, g_what) != 4) return;
  g_armed = 1;
}

static int ends_with(const char* s, const char* tail) {
  const size_t a = strlen(s), b = strlen(tail);
  return a >= b && strcmp(s + a - b, tail) == 0;
}

// Whether `fd` is a file of the armed kind.
static int of_kind(int fd) {
  char link[64], path[4096];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  const ssize_t n = readlink(link, path, sizeof path - 1);
  if (n <= 0) return 0;
  path[n] = '\0';
  if (strcmp(g_kind, "segment") == 0) return ends_with(path, ".mkv");
  if (strcmp(g_kind, "index") == 0) return ends_with(path, "/session.db");
  if (strcmp(g_kind, "wal") == 0) return ends_with(path, "/session.db-wal");
  if (strcmp(g_kind, "spill") == 0) return ends_with(path, ".spill");
  return 0;
}

static long g_slow_ms;

// 0: pass the call on; 1: fail it with EIO; 2: write half of it; 3: pass it on g_slow_ms late.
static int decide(int fd, const char* op) {
  arm();
  if (g_armed != 1 || strcmp(g_op, op) != 0 || !of_kind(fd)) return 0;
  const long k = __atomic_add_fetch(&g_count, 1, __ATOMIC_SEQ_CST);
  if (k < g_n) return 0;
  if (strcmp(g_what, "short") == 0) return k == g_n ? 2 : 0;
  if (strncmp(g_what, "slow", 4) == 0) {
    g_slow_ms = atol(g_what + 4);
    return k == g_n ? 3 : 0;
  }
  return 1;
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
  switch (decide(fd, "write")) {
    case 1:
      errno = EIO;
      return -1;
    case 2:
      return real_write(fd, buf, count > 1 ? count / 2 : count);
  }
  return real_write(fd, buf, count);
}

ssize_t pwrite64(int fd, const void* buf, size_t count, off_t offset) {
  REAL(pwrite64, pwrite_fn);
  switch (decide(fd, "write")) {
    case 1:
      errno = EIO;
      return -1;
    case 2:
      return real_pwrite64(fd, buf, count > 1 ? count / 2 : count, offset);
  }
  return real_pwrite64(fd, buf, count, offset);
}

ssize_t pwrite(int fd, const void* buf, size_t count, off_t offset) { return pwrite64(fd, buf, count, offset); }

ssize_t writev(int fd, const struct iovec* iov, int iovcnt) {
  REAL(writev, writev_fn);
  switch (decide(fd, "write")) {
    case 1:
      errno = EIO;
      return -1;
    case 2:
      return iovcnt > 0 ? real_writev(fd, iov, 1) : 0;  // the first part only: short
  }
  return real_writev(fd, iov, iovcnt);
}

ssize_t pwritev64(int fd, const struct iovec* iov, int iovcnt, off_t offset) {
  REAL(pwritev64, pwritev_fn);
  switch (decide(fd, "write")) {
    case 1:
      errno = EIO;
      return -1;
    case 2:
      return iovcnt > 0 ? real_pwritev64(fd, iov, 1, offset) : 0;
  }
  return real_pwritev64(fd, iov, iovcnt, offset);
}

ssize_t pwritev(int fd, const struct iovec* iov, int iovcnt, off_t offset) {
  return pwritev64(fd, iov, iovcnt, offset);
}

// fsync and fdatasync fail alike.
static int failing_sync(int fd, sync_fn real) {
  switch (decide(fd, "fsync")) {
    case 1:
      errno = EIO;
      return -1;
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
