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

// For a process that reads recorded images frame after frame (calibration, export, replay's render,
// the report's self-check, compact), never for a recorder (above). Each frame allocates and frees
// image-sized buffers (1-6 MB: decoded planes, demosaicked copies, OpenCV's temporaries); glibc
// serves them with mmap and trims freed heap tops back to the kernel, so every frame's buffers were
// fresh pages, faulted in and zeroed: 18 % of `calibrate intrinsics`. Blocks up to 32 MB (a 4K
// colour image) now stay in the heap and are reused, with at most 128 MB of free heap kept. On a
// 25 s board session of four 1080p cameras: 25.8 s -> 15.0 s, peak memory 172 -> 185 MB.
inline void keep_image_buffers_in_heap() {
  (void)mallopt(M_MMAP_THRESHOLD, 32 << 20);
  (void)mallopt(M_TRIM_THRESHOLD, 128 << 20);
}

}  // namespace pvcap
