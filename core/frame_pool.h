#pragma once
// Reusable image buffers for frames handed from one thread to another (camera worker -> encoder).
//
// A 1080p BGR image is 6 MB: allocated fresh per frame, glibc maps it anew (or grows and trims a
// thread's heap) and every first touch of its pages faults. On a VM that costs more than the
// debayering that fills it. The pool keeps a few buffers and hands out one that nobody else holds
// any more; the receiving thread simply drops its cv::Mat when done, and the buffer is free again.
#include <cstddef>
#include <vector>

#include <opencv2/core.hpp>

namespace pvcap {

class FramePool {
 public:
  explicit FramePool(std::size_t capacity) : capacity_(capacity) {}

  // A rows x cols image of `type` that no other cv::Mat shares. Its pixels are whatever the buffer
  // held before: the caller overwrites them. When every pooled buffer is still in use (the consumer
  // is behind by more than the capacity), a fresh one is returned and not kept.
  cv::Mat acquire(int rows, int cols, int type) {
    for (cv::Mat& m : buffers_)
      // Only the pool holds it: nobody else can take a new reference, so the count cannot rise meanwhile.
      if (m.u && CV_XADD(&m.u->refcount, 0) == 1 && m.rows == rows && m.cols == cols && m.type() == type) return m;
    cv::Mat fresh(rows, cols, type);
    if (buffers_.size() < capacity_) {
      buffers_.push_back(fresh);
    } else {
      // Buffers of another size (the camera's ROI changed) make room for this one.
      for (cv::Mat& m : buffers_)
        if (m.u && CV_XADD(&m.u->refcount, 0) == 1) {
          m = fresh;
          break;
        }
    }
    return fresh;
  }

  std::size_t size() const { return buffers_.size(); }

 private:
  std::size_t capacity_;
  std::vector<cv::Mat> buffers_;
};

}  // namespace pvcap
