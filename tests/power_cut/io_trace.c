// An LD_PRELOAD interposer for the power-cut tests: it records, in the order they took effect,
// every write, truncation, sync and name change a process makes under one folder, with the bytes
// written, so tests/power_cut/crash_image.h can build that folder as a power cut at any moment
// would have left it (the method of SQLite's crash tests and of ALICE). Set in the environment:
//   PVCAP_IO_TRACE=DIR        the trace goes to DIR/ops (records) and DIR/data (the bytes written)
//   PVCAP_IO_TRACE_ROOT=PATH  only files and folders under PATH (absolute) are recorded
// Only the process that starts with them set is traced: both are removed from its environment, so
// the simulated devices it spawns are not. Unset: every call goes straight to libc. Calls are
// serialised by one lock held across the call and its record, so the record order is the order
// the kernel saw them. Writes through mmap (SQLite's -shm, which a power cut does not keep either)
// and through stdio (which glibc makes without its exported write) are not seen.
// Test instrument only: nothing of pvcap links it.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <time.h>
#include <unistd.h>

#include "../preload_paths.h"
#include "trace_format.h"

static pthread_mutex_t g_lock = PTHREAD_MUTEX_INITIALIZER;
static int g_ops_fd = -1, g_data_fd = -1;
static int64_t g_data_pos;
static int64_t g_ops_recorded; /* records written so far: a sync's starting point */
static char g_root[PATH_MAX];
static size_t g_root_len;
static __thread int t_inside;  // our own calls are not traced

__attribute__((constructor)) static void trace_init(void) {
  const char* dir = getenv("PVCAP_IO_TRACE");
  const char* root = getenv("PVCAP_IO_TRACE_ROOT");
  if (!dir || !root || root[0] != '/') return;
  snprintf(g_root, sizeof g_root, "%s", root);
  g_root_len = strlen(g_root);
  while (g_root_len > 1 && g_root[g_root_len - 1] == '/') g_root[--g_root_len] = '\0';
  char path[PATH_MAX];
  snprintf(path, sizeof path, "%s/ops", dir);
  g_ops_fd = (int)syscall(SYS_openat, AT_FDCWD, path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  snprintf(path, sizeof path, "%s/data", dir);
  g_data_fd = (int)syscall(SYS_openat, AT_FDCWD, path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (g_ops_fd < 0 || g_data_fd < 0) {
    fprintf(stderr, "io_trace: cannot write the trace under %s\n", dir);
    abort();
  }
  unsetenv("PVCAP_IO_TRACE");
  unsetenv("PVCAP_IO_TRACE_ROOT");
  unsetenv("LD_PRELOAD");
}

static int tracing(void) { return g_ops_fd >= 0 && !t_inside; }

static void put_all(int fd, const void* p, size_t n) {
  const char* c = p;
  while (n > 0) {
    const ssize_t w = syscall(SYS_write, fd, c, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      fprintf(stderr, "io_trace: the trace could not be written\n");
      abort();
    }
    c += w;
    n -= (size_t)w;
  }
}

static int under_root(const char* path) {
  return strncmp(path, g_root, g_root_len) == 0 && (path[g_root_len] == '/' || path[g_root_len] == '\0');
}

// The path of the file `fd` has open, if it is under the root and still has a name.
static int path_of_fd(int fd, char* out, size_t size) {
  char link[64];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  const ssize_t n = readlink(link, out, size - 1);
  if (n <= 0) return 0;
  out[n] = '\0';
  if (n > 10 && strcmp(out + n - 10, " (deleted)") == 0) return 0;
  return under_root(out);
}

static int64_t now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static void record(uint32_t op, uint32_t flags, const char* path, const char* path2, int64_t offset, int64_t length,
                   const struct iovec* data, int data_parts) {
  struct trace_record r;
  memset(&r, 0, sizeof r);
  r.magic = TRACE_MAGIC;
  r.op = op;
  r.flags = flags;
  r.path_len = (uint32_t)strlen(path);
  r.path2_len = path2 ? (uint32_t)strlen(path2) : 0;
  r.t_ns = now_ns();
  r.offset = offset;
  r.length = length;
  r.data_pos = data ? g_data_pos : -1;
  if (data) {
    int64_t left = length;
    for (int i = 0; i < data_parts && left > 0; ++i) {
      const size_t n = (size_t)(left < (int64_t)data[i].iov_len ? left : (int64_t)data[i].iov_len);
      put_all(g_data_fd, data[i].iov_base, n);
      left -= (int64_t)n;
    }
    g_data_pos += length;
  }
  put_all(g_ops_fd, &r, sizeof r);
  ++g_ops_recorded;
  put_all(g_ops_fd, path, r.path_len);
  if (path2) put_all(g_ops_fd, path2, r.path2_len);
}

#define REAL(name)                      \
  static __typeof__(&name) real_##name; \
  if (!real_##name) real_##name = (__typeof__(&name))dlsym(RTLD_NEXT, #name)

#define LOCKED(call_expr, after)   \
  do {                             \
    pthread_mutex_lock(&g_lock);   \
    t_inside = 1;                  \
    rc = call_expr;                \
    const int saved = errno;       \
    t_inside = 0;                  \
    after;                         \
    pthread_mutex_unlock(&g_lock); \
    errno = saved;                 \
  } while (0)

// ---- writes ----

// The write itself runs outside the lock (a write can wait on the kernel's dirty-page throttling;
// under the lock every thread's writes waited with it, and at 1080p the traced recorder fell behind):
// it is recorded once done. A sync begun meanwhile counts it as after itself (TRACE_SYNC_FROM), which
// can only make the crash image lose more, never keep what the disk would not.
static ssize_t traced_write(int fd, const struct iovec* iov, int parts, int64_t offset, ssize_t (*call)(void*),
                            void* ctx) {
  char path[PATH_MAX];
  const int traced = path_of_fd(fd, path, sizeof path);
  if (traced && offset < 0) {
    // write()/writev(): at the descriptor's position, or at the end for O_APPEND (each file here has
    // one writing thread, so nothing moves it between this and the write).
    const int fl = fcntl(fd, F_GETFL);
    struct stat st;
    offset = (fl >= 0 && (fl & O_APPEND) && fstat(fd, &st) == 0) ? st.st_size : lseek(fd, 0, SEEK_CUR);
  }
  t_inside = 1;
  const ssize_t rc = call(ctx);
  const int saved = errno;
  t_inside = 0;
  if (traced && rc > 0) {
    pthread_mutex_lock(&g_lock);
    record(TRACE_WRITE, 0, path, NULL, offset, rc, iov, parts);
    pthread_mutex_unlock(&g_lock);
  }
  errno = saved;
  return rc;
}

struct wctx {
  int fd;
  const struct iovec* iov;
  int parts;
  off_t offset;
};

static ssize_t do_writev(void* p) {
  struct wctx* c = p;
  REAL(writev);
  return real_writev(c->fd, c->iov, c->parts);
}
static ssize_t do_pwritev(void* p) {
  struct wctx* c = p;
  REAL(pwritev64);
  return real_pwritev64(c->fd, c->iov, c->parts, c->offset);
}

ssize_t write(int fd, const void* buf, size_t count) {
  REAL(write);
  if (!tracing()) return real_write(fd, buf, count);
  struct iovec v = {(void*)buf, count};
  struct wctx c = {fd, &v, 1, 0};
  return traced_write(fd, &v, 1, -1, do_writev, &c);
}

ssize_t writev(int fd, const struct iovec* iov, int parts) {
  REAL(writev);
  if (!tracing()) return real_writev(fd, iov, parts);
  struct wctx c = {fd, iov, parts, 0};
  return traced_write(fd, iov, parts, -1, do_writev, &c);
}

ssize_t pwrite64(int fd, const void* buf, size_t count, off_t offset) {
  REAL(pwrite64);
  if (!tracing()) return real_pwrite64(fd, buf, count, offset);
  struct iovec v = {(void*)buf, count};
  struct wctx c = {fd, &v, 1, offset};
  return traced_write(fd, &v, 1, offset, do_pwritev, &c);
}
ssize_t pwrite(int fd, const void* buf, size_t count, off_t offset) { return pwrite64(fd, buf, count, offset); }

ssize_t pwritev64(int fd, const struct iovec* iov, int parts, off_t offset) {
  REAL(pwritev64);
  if (!tracing()) return real_pwritev64(fd, iov, parts, offset);
  struct wctx c = {fd, iov, parts, offset};
  return traced_write(fd, iov, parts, offset, do_pwritev, &c);
}
ssize_t pwritev(int fd, const struct iovec* iov, int parts, off_t offset) { return pwritev64(fd, iov, parts, offset); }

// ---- sizes and syncs ----

static int traced_fd_op(int fd, uint32_t op, int64_t length, int (*call)(int, int64_t, int64_t), int64_t a, int64_t b) {
  int rc;
  if (!tracing()) return call(fd, a, b);
  char path[PATH_MAX];
  LOCKED(call(fd, a, b),
         if (rc == 0 && path_of_fd(fd, path, sizeof path)) record(op, 0, path, NULL, 0, length, NULL, 0));
  return rc;
}

static int call_ftruncate(int fd, int64_t length, int64_t unused) {
  (void)unused;
  REAL(ftruncate64);
  return real_ftruncate64(fd, length);
}
static int call_fsync(int fd, int64_t a, int64_t b) {
  (void)a, (void)b;
  REAL(fsync);
  return real_fsync(fd);
}
static int call_fdatasync(int fd, int64_t a, int64_t b) {
  (void)a, (void)b;
  REAL(fdatasync);
  return real_fdatasync(fd);
}
// posix_fallocate returns its error instead of setting errno; a size that grows is what matters.
static int call_fallocate(int fd, int64_t offset, int64_t length) {
  REAL(posix_fallocate64);
  const int e = real_posix_fallocate64(fd, offset, length);
  if (e) errno = e;
  return e ? -1 : 0;
}

int ftruncate64(int fd, off_t length) { return traced_fd_op(fd, TRACE_TRUNCATE, length, call_ftruncate, length, 0); }
int ftruncate(int fd, off_t length) { return ftruncate64(fd, length); }
// A sync runs outside the lock: a second-long fsync of a 1080p segment must not hold every other
// thread's writes (under the lock the recorder fell so far behind that its own durability broke).
// It is recorded when it returns, with the number of ops recorded before it began (TRACE_SYNC_FROM):
// only those are surely covered.
static int traced_sync(int fd, int (*call)(int, int64_t, int64_t)) {
  if (!tracing()) return call(fd, 0, 0);
  char path[PATH_MAX];
  pthread_mutex_lock(&g_lock);
  const int64_t from = g_ops_recorded;
  pthread_mutex_unlock(&g_lock);
  t_inside = 1;
  const int rc = call(fd, 0, 0);
  const int saved = errno;
  t_inside = 0;
  pthread_mutex_lock(&g_lock);
  if (rc == 0 && path_of_fd(fd, path, sizeof path)) record(TRACE_SYNC, TRACE_SYNC_FROM, path, NULL, from, 0, NULL, 0);
  pthread_mutex_unlock(&g_lock);
  errno = saved;
  return rc;
}
int fsync(int fd) { return traced_sync(fd, call_fsync); }
int fdatasync(int fd) { return traced_sync(fd, call_fdatasync); }
int posix_fallocate64(int fd, off_t offset, off_t length) {
  struct stat st;
  const int64_t end = offset + length;
  int64_t size = end;
  if (fstat(fd, &st) == 0 && st.st_size > end) size = st.st_size;
  const int rc = traced_fd_op(fd, TRACE_TRUNCATE, size, call_fallocate, offset, length);
  return rc == 0 ? 0 : errno;
}
int posix_fallocate(int fd, off_t offset, off_t length) { return posix_fallocate64(fd, offset, length); }

// ---- names ----

static int open_common(int dirfd, const char* name, int flags, mode_t mode) {
  REAL(openat64);
  if (!tracing()) return real_openat64(dirfd, name, flags, mode);
  char path[PATH_MAX];
  int rc;
  pthread_mutex_lock(&g_lock);
  const int traced =
      (flags & (O_CREAT | O_TRUNC)) && preload_absolute_path(dirfd, name, path, sizeof path) && under_root(path);
  const int existed = traced && access(path, F_OK) == 0;
  t_inside = 1;
  rc = real_openat64(dirfd, name, flags, mode);
  const int saved = errno;
  t_inside = 0;
  if (traced && rc >= 0 && (!existed || (flags & O_TRUNC)))
    record(TRACE_OPEN, (existed ? 0 : TRACE_CREATED) | ((flags & O_TRUNC) ? TRACE_TRUNCATED : 0), path, NULL, 0, 0,
           NULL, 0);
  pthread_mutex_unlock(&g_lock);
  errno = saved;
  return rc;
}

static mode_t mode_arg(int flags, va_list ap) { return (flags & (O_CREAT | O_TMPFILE)) ? va_arg(ap, mode_t) : 0; }

int open(const char* name, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  const mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  return open_common(AT_FDCWD, name, flags, mode);
}
int open64(const char* name, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  const mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  return open_common(AT_FDCWD, name, flags, mode);
}
int openat(int dirfd, const char* name, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  const mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  return open_common(dirfd, name, flags, mode);
}
int openat64(int dirfd, const char* name, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  const mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  return open_common(dirfd, name, flags, mode);
}
int __open_2(const char* name, int flags) { return open_common(AT_FDCWD, name, flags, 0); }
int __open64_2(const char* name, int flags) { return open_common(AT_FDCWD, name, flags, 0); }
int __openat_2(int dirfd, const char* name, int flags) { return open_common(dirfd, name, flags, 0); }
int __openat64_2(int dirfd, const char* name, int flags) { return open_common(dirfd, name, flags, 0); }
int creat(const char* name, mode_t mode) { return open_common(AT_FDCWD, name, O_CREAT | O_WRONLY | O_TRUNC, mode); }
int creat64(const char* name, mode_t mode) { return creat(name, mode); }

// A name change under the root (or into it, or out of it).
static int traced_names(uint32_t op, int dirfd, const char* name, int dirfd2, const char* name2, int (*call)(void*),
                        void* ctx) {
  if (!tracing()) return call(ctx);
  char path[PATH_MAX], path2[PATH_MAX];
  int rc;
  pthread_mutex_lock(&g_lock);
  const int ok = preload_absolute_path(dirfd, name, path, sizeof path) &&
                 (!name2 || preload_absolute_path(dirfd2, name2, path2, sizeof path2));
  t_inside = 1;
  rc = call(ctx);
  const int saved = errno;
  t_inside = 0;
  if (ok && rc == 0 && (under_root(path) || (name2 && under_root(path2))))
    record(op, 0, path, name2 ? path2 : NULL, 0, 0, NULL, 0);
  pthread_mutex_unlock(&g_lock);
  errno = saved;
  return rc;
}

struct nctx {
  int dirfd;
  const char* name;
  int dirfd2;
  const char* name2;
  int flags;
  mode_t mode;
};

static int do_renameat2(void* p) {
  struct nctx* c = p;
  return (int)syscall(SYS_renameat2, c->dirfd, c->name, c->dirfd2, c->name2, c->flags);
}
static int do_unlinkat(void* p) {
  struct nctx* c = p;
  return (int)syscall(SYS_unlinkat, c->dirfd, c->name, c->flags);
}
static int do_mkdirat(void* p) {
  struct nctx* c = p;
  return (int)syscall(SYS_mkdirat, c->dirfd, c->name, c->mode);
}

int renameat2(int dirfd, const char* name, int dirfd2, const char* name2, unsigned flags) {
  struct nctx c = {dirfd, name, dirfd2, name2, (int)flags, 0};
  return traced_names(TRACE_RENAME, dirfd, name, dirfd2, name2, do_renameat2, &c);
}
int renameat(int dirfd, const char* name, int dirfd2, const char* name2) {
  return renameat2(dirfd, name, dirfd2, name2, 0);
}
int rename(const char* name, const char* name2) { return renameat2(AT_FDCWD, name, AT_FDCWD, name2, 0); }

int unlinkat(int dirfd, const char* name, int flags) {
  struct nctx c = {dirfd, name, 0, NULL, flags, 0};
  return traced_names(TRACE_UNLINK, dirfd, name, 0, NULL, do_unlinkat, &c);
}
int unlink(const char* name) { return unlinkat(AT_FDCWD, name, 0); }
int rmdir(const char* name) { return unlinkat(AT_FDCWD, name, AT_REMOVEDIR); }
/* C's remove(), which std::filesystem::remove calls: glibc's calls its unlink and rmdir inside the
 * library, past this interposer, so a removed journal or spill file would be missing from the trace. */
int remove(const char* name) {
  const int rc = unlinkat(AT_FDCWD, name, 0);
  if (rc != 0 && (errno == EISDIR || errno == EPERM)) return unlinkat(AT_FDCWD, name, AT_REMOVEDIR);
  return rc;
}

int mkdirat(int dirfd, const char* name, mode_t mode) {
  struct nctx c = {dirfd, name, 0, NULL, 0, mode};
  return traced_names(TRACE_MKDIR, dirfd, name, 0, NULL, do_mkdirat, &c);
}
int mkdir(const char* name, mode_t mode) { return mkdirat(AT_FDCWD, name, mode); }
