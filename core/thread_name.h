#pragma once
// Names the calling thread, as `top -H`, `perf` and the capture bench show it: "watch-cam0" reads
// better than a dozen threads all called "pvcap". Linux keeps 15 characters; the role goes first,
// so a long camera name loses its end, not the role.
#include <pthread.h>

#include <string>

namespace pvcap {

inline void name_this_thread(std::string name) {
  if (name.size() > 15) name.resize(15);
  pthread_setname_np(pthread_self(), name.c_str());
}

}  // namespace pvcap
