#pragma once
// SQLite's unix VFS with one change: the sync of a folder is checked. SQLite fsyncs the folder of
// each rollback journal or WAL it creates, once, at the new file's first sync, and ignores what the
// fsync returns (os_unix.c, unixSync), so a disk that failed it went unseen: the session recorded
// on, exit 0 (bench/io_faults.py, every fsync: three of a session's ~107 were such).
// Here SQLite's "openDirectory" system call is replaced by one that fsyncs the folder itself and
// keeps a failure, and the sync (or delete) that asked for it then fails: SQLITE_IOERR_DIR_FSYNC,
// the operating system's error kept for the message (sqlite3_system_errno).
#include <string>

namespace pvcap::sqlite {

// The VFS's name for sqlite3_open_v2; registered (once, never as the default) on the first call.
// nullptr when this SQLite lacks what it needs: SQLite's default VFS, unchecked, as before.
const char* checked_vfs_name();

// This thread's last failed sync, taken once: SQLite keeps no errno for a sync that fails at a
// commit (sqlite3_system_errno says 0), so the message takes it from here.
struct SyncFailure {
  int error = 0;       // errno; 0: none
  std::string folder;  // the folder whose fsync failed; empty: the file's own
};
SyncFailure take_sync_failure();

}  // namespace pvcap::sqlite
