#include "export/numpy_files.h"

#include <cstdint>
#include <stdexcept>

#include <fmt/format.h>

namespace pvcap::exporting {

namespace {

void check(const cv::Mat& a) {
  if (a.type() != CV_32F || a.dims != 2 || !a.isContinuous())
    throw std::invalid_argument("numpy arrays are written from continuous 2-D CV_32F matrices");
}

void put_u32(std::string& s, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s += char((v >> (8 * i)) & 0xFF);
}

// A pickle BININT1 / BININT2 / BININT for a non-negative int.
void put_int(std::string& s, std::uint32_t v) {
  if (v < 256) {
    s += 'K';
    s += char(v);
  } else if (v < 65536) {
    s += 'M';
    s += char(v & 0xFF);
    s += char(v >> 8);
  } else {
    s += 'J';
    put_u32(s, v);
  }
}

void put_unicode(std::string& s, const std::string& text) {
  s += 'X';
  put_u32(s, std::uint32_t(text.size()));
  s += text;
}

}  // namespace

std::string numpy_pickle(const cv::Mat& a) {
  check(a);
  std::string s = "\x80\x03";
  int memo = 0;
  auto put = [&] {  // BINPUT: numpy's pickler memoises every object it makes
    s += 'q';
    s += char(memo++);
  };
  // numpy.core.multiarray._reconstruct(numpy.ndarray, (0,), b'b')
  s += "cnumpy.core.multiarray\n_reconstruct\n";
  put();
  s += "cnumpy\nndarray\n";
  put();
  s += std::string("K\x00\x85", 3);
  put();
  s += std::string(
      "C\x01"
      "b",
      3);
  put();
  s += '\x87';
  put();
  s += 'R';
  put();
  // .__setstate__((1, shape, dtype('<f4'), False, data))
  s += "(K\x01";
  put_int(s, std::uint32_t(a.rows));
  put_int(s, std::uint32_t(a.cols));
  s += '\x86';
  put();
  s += "cnumpy\ndtype\n";
  put();
  put_unicode(s, "f4");
  put();
  s += "\x89\x88\x87";  // dtype('f4', False, True)
  put();
  s += 'R';
  put();
  s += "(K\x03";
  put_unicode(s, "<");
  put();
  s += std::string("NNNJ\xff\xff\xff\xffJ\xff\xff\xff\xffK\x00t", 16);
  put();
  s += "b\x89";
  const std::size_t bytes = a.total() * sizeof(float);
  if (bytes < 256) {
    s += 'C';
    s += char(bytes);
  } else {
    s += 'B';
    put_u32(s, std::uint32_t(bytes));
  }
  s.append(reinterpret_cast<const char*>(a.data), bytes);
  put();
  s += 't';
  put();
  s += "b.";
  return s;
}

std::string numpy_npy(const cv::Mat& a) {
  check(a);
  std::string header = fmt::format("{{'descr': '<f4', 'fortran_order': False, 'shape': ({}, {}), }}", a.rows, a.cols);
  // Magic, version 1.0, header length; the header padded with spaces to a multiple of 64, then '\n'.
  const std::size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  std::string s = "\x93NUMPY\x01";
  s += '\x00';
  s += char(header.size() & 0xFF);
  s += char(header.size() >> 8);
  s += header;
  s.append(reinterpret_cast<const char*>(a.data), a.total() * sizeof(float));
  return s;
}

}  // namespace pvcap::exporting
