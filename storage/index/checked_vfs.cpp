#include "storage/index/checked_vfs.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <mutex>
#include <string>
#include <utility>

#include <sqlite3.h>

namespace pvcap::sqlite {

namespace {

sqlite3_vfs* g_unix = nullptr;  // SQLite's own, which does every other thing
sqlite3_vfs g_checked{};

// This thread's last failed sync (of a folder, or a file), until a message takes it; and how many
// folder syncs failed, by which a sync or delete knows that one it asked for did.
thread_local SyncFailure t_failure;
thread_local unsigned t_folder_failures = 0;

// Stands in for the unix VFS's openDirectory, which it calls only to fsync the folder of `path` and
// then drops the fsync's result: the folder is synced here, a failure kept, and SQLite told the folder
// cannot be opened, which makes it skip its own (unchecked) fsync. A folder that cannot be opened is
// passed over, as SQLite does.
int open_directory_and_sync(const char* path, int* fd) {
  *fd = -1;
  std::string folder(path);
  const auto slash = folder.rfind('/');
  folder = slash == std::string::npos ? "." : slash == 0 ? "/" : folder.substr(0, slash);
  const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    if (::fsync(dir) != 0) {
      t_failure = {errno ? errno : EIO, folder};
      ++t_folder_failures;
    }
    ::close(dir);
  }
  return SQLITE_CANTOPEN;
}

// An open file: a sqlite3_file whose methods are kMethods (none when the open failed), then, from
// kHeader on, the unix VFS's own file object, which every call is passed on to.
constexpr int kHeader = (sizeof(sqlite3_file) + 7) & ~7;

sqlite3_file* real(sqlite3_file* f) { return reinterpret_cast<sqlite3_file*>(reinterpret_cast<char*>(f) + kHeader); }
const sqlite3_io_methods& real_methods(sqlite3_file* f) { return *real(f)->pMethods; }

// What the call returned, or the folder sync it made (after `before` failures) failing; a failure
// kept for its message.
int checked(int rc, unsigned before) {
  const int error = errno;
  if (t_folder_failures != before) return rc == SQLITE_OK ? SQLITE_IOERR_DIR_FSYNC : rc;
  if (rc != SQLITE_OK) t_failure = {error ? error : EIO, {}};
  return rc;
}

int x_close(sqlite3_file* f) { return real_methods(f).xClose(real(f)); }
int x_read(sqlite3_file* f, void* buf, int n, sqlite3_int64 at) { return real_methods(f).xRead(real(f), buf, n, at); }
int x_write(sqlite3_file* f, const void* buf, int n, sqlite3_int64 at) {
  return real_methods(f).xWrite(real(f), buf, n, at);
}
int x_truncate(sqlite3_file* f, sqlite3_int64 size) { return real_methods(f).xTruncate(real(f), size); }
int x_sync(sqlite3_file* f, int flags) {
  const unsigned before = t_folder_failures;
  return checked(real_methods(f).xSync(real(f), flags), before);
}
int x_file_size(sqlite3_file* f, sqlite3_int64* size) { return real_methods(f).xFileSize(real(f), size); }
int x_lock(sqlite3_file* f, int level) { return real_methods(f).xLock(real(f), level); }
int x_unlock(sqlite3_file* f, int level) { return real_methods(f).xUnlock(real(f), level); }
int x_check_reserved_lock(sqlite3_file* f, int* out) { return real_methods(f).xCheckReservedLock(real(f), out); }
int x_file_control(sqlite3_file* f, int op, void* arg) { return real_methods(f).xFileControl(real(f), op, arg); }
int x_sector_size(sqlite3_file* f) { return real_methods(f).xSectorSize(real(f)); }
int x_device_characteristics(sqlite3_file* f) { return real_methods(f).xDeviceCharacteristics(real(f)); }
int x_shm_map(sqlite3_file* f, int region, int size, int extend, void volatile** out) {
  return real_methods(f).xShmMap(real(f), region, size, extend, out);
}
int x_shm_lock(sqlite3_file* f, int offset, int n, int flags) {
  return real_methods(f).xShmLock(real(f), offset, n, flags);
}
void x_shm_barrier(sqlite3_file* f) { real_methods(f).xShmBarrier(real(f)); }
int x_shm_unmap(sqlite3_file* f, int remove) { return real_methods(f).xShmUnmap(real(f), remove); }
int x_fetch(sqlite3_file* f, sqlite3_int64 at, int n, void** out) {
  return real_methods(f).xFetch(real(f), at, n, out);
}
int x_unfetch(sqlite3_file* f, sqlite3_int64 at, void* p) { return real_methods(f).xUnfetch(real(f), at, p); }

// Version 3, as the unix VFS's own files are (checked at registration).
const sqlite3_io_methods kMethods = {3,
                                     x_close,
                                     x_read,
                                     x_write,
                                     x_truncate,
                                     x_sync,
                                     x_file_size,
                                     x_lock,
                                     x_unlock,
                                     x_check_reserved_lock,
                                     x_file_control,
                                     x_sector_size,
                                     x_device_characteristics,
                                     x_shm_map,
                                     x_shm_lock,
                                     x_shm_barrier,
                                     x_shm_unmap,
                                     x_fetch,
                                     x_unfetch};

int x_open(sqlite3_vfs*, const char* name, sqlite3_file* file, int flags, int* out_flags) {
  file->pMethods = nullptr;
  const int rc = g_unix->xOpen(g_unix, name, real(file), flags, out_flags);
  if (real(file)->pMethods) file->pMethods = &kMethods;  // closed through it, even when the open failed
  return rc;
}

int x_delete(sqlite3_vfs*, const char* name, int sync_folder) {
  const unsigned before = t_folder_failures;
  return checked(g_unix->xDelete(g_unix, name, sync_folder), before);
}

}  // namespace

SyncFailure take_sync_failure() { return std::exchange(t_failure, {}); }

const char* checked_vfs_name() {
  static std::once_flag once;
  static const char* name = nullptr;
  std::call_once(once, [] {
    g_unix = sqlite3_vfs_find("unix");
    if (!g_unix || g_unix->iVersion < 3 || !g_unix->xSetSystemCall) return;  // another build of SQLite
    // Every unix VFS of the process syncs its folders through it: it does what SQLite did, and more.
    if (g_unix->xSetSystemCall(g_unix, "openDirectory",
                               reinterpret_cast<sqlite3_syscall_ptr>(open_directory_and_sync)) != SQLITE_OK)
      return;
    g_checked = *g_unix;
    g_checked.pNext = nullptr;
    g_checked.zName = "pvcap-checked-unix";
    g_checked.szOsFile = kHeader + g_unix->szOsFile;
    g_checked.xOpen = x_open;
    g_checked.xDelete = x_delete;
    if (sqlite3_vfs_register(&g_checked, 0) == SQLITE_OK) name = g_checked.zName;
  });
  return name;
}

}  // namespace pvcap::sqlite
