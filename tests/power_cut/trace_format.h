// The records tests/power_cut/io_trace.c writes and tests/power_cut/crash_image.cpp reads: a fixed
// header, then the path (and the second path of a rename), not NUL-terminated. The bytes of a
// write are at data_pos in the trace's data file.
#ifndef PVCAP_TESTS_POWER_CUT_TRACE_FORMAT_H
#define PVCAP_TESTS_POWER_CUT_TRACE_FORMAT_H

#include <stdint.h>

#define TRACE_MAGIC 0x50435554u /* "PCUT" */

enum trace_op {
  TRACE_WRITE = 1,    /* length bytes at offset */
  TRACE_TRUNCATE = 2, /* the file's size set to length (ftruncate, or grown by posix_fallocate) */
  TRACE_SYNC = 3,     /* fsync or fdatasync of a file or a folder, recorded when it returned; with
                         TRACE_SYNC_FROM, offset is the number of ops recorded before it was called:
                         what they wrote is on the disk, later ones (made while it ran) may not be */
  TRACE_OPEN = 4,     /* a file created (TRACE_CREATED) and/or emptied (TRACE_TRUNCATED) by open */
  TRACE_RENAME = 5,   /* path renamed to path2 */
  TRACE_UNLINK = 6,   /* path removed (a file or an empty folder) */
  TRACE_MKDIR = 7,    /* a folder made */
};

enum trace_flags { TRACE_CREATED = 1, TRACE_TRUNCATED = 2, TRACE_SYNC_FROM = 4 };

struct trace_record {
  uint32_t magic;
  uint32_t op;
  uint32_t flags;
  uint32_t path_len;
  uint32_t path2_len;
  uint32_t reserved;
  int64_t t_ns; /* CLOCK_MONOTONIC, the clock of the index's host_ns */
  int64_t offset;
  int64_t length;
  int64_t data_pos; /* -1: no bytes */
};

#endif
