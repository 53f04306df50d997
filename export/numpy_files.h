#pragma once
// A float32 2-D array as Python reads it, written without Python: a pickle (protocol 3, exactly
// the bytes numpy's own pickle.dumps(array, protocol=3) makes, so pickle.load gives an ndarray) and
// the portable .npy format (numpy's NEP 1 header, version 1.0).
#include <string>

#include <opencv2/core.hpp>

namespace pvcap::exporting {

std::string numpy_pickle(const cv::Mat& array);  // CV_32F, continuous, 2-D
std::string numpy_npy(const cv::Mat& array);

}  // namespace pvcap::exporting
