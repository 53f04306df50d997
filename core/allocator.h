#pragma once
// The process's allocator, kept from growing over a long recording.
//
// Frame-sized buffers are allocated on one thread and freed on another; glibc keeps the freed
// space in its arenas, fragmented, and a recorder's memory crept up with time: measured on a
// simulated 4-camera session, anonymous memory grew 16 MB in 4 minutes (RSS 54 MB in 20) while
// the live heap stayed at 69 MB (heaptrack). Handing the arenas' free pages back every two seconds
// (the recording's progress line) kept it to 80 -> 84 MB over the same 4 minutes. (A fixed mmap
// threshold did as well, 77 -> 81 MB, but cost the raw store 15 % of its encoding rate in page
// faults: bench/store_bench, 200 -> 170 frames/s.)
#include <malloc.h>

namespace pvcap {

// Returns the arenas' free pages to the system; a few milliseconds. Call from a thread that may wait.
inline void return_free_memory() { (void)malloc_trim(0); }

}  // namespace pvcap
