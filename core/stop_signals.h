#pragma once
// How a pvcap process stops: Ctrl-C, SIGTERM and a hang-up (a dropped ssh, a closed window) ask it to
// stop cleanly; a second Ctrl-C or SIGTERM leaves at once. Process-wide: installed once, by main.
#include <atomic>
#include <filesystem>

namespace pvcap {

// Whether the process was started with hang-ups ignored (`nohup pvcap session ...`, a `trap '' HUP`):
// the user asked for it to outlive the terminal, and pvcap keeps to that.
bool hangups_ignored_by_the_caller();

// Sets `stop` on SIGINT, SIGTERM and (unless `keep_hangups_ignored`) SIGHUP; exits 130 on a second
// SIGINT or SIGTERM. After a hang-up, what went to the dead terminal goes to /dev/null (a write to it
// would fail with EIO; the session's log file keeps every line). SIGPIPE and SIGTTOU are ignored: a
// closed pipe or socket is an error return, and a background job may write to its terminal.
void install_stop_handlers(std::atomic<bool>& stop, bool keep_hangups_ignored);

// This program's own file (/proc/self/exe), for the processes it starts again; "pvcap" if unknown.
std::filesystem::path self_exe();

// Lowers the process's priority to `nice` if it runs higher (every thread started later inherits
// it); returns the nice it runs at then. current_nice: the nice it runs at. Both INT_MIN when it
// cannot be read.
int lower_priority_to(int nice);
int current_nice();

}  // namespace pvcap
