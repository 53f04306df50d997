#include "tests/integration/picture_files.h"

#include <csetjmp>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <jpeglib.h>  // after <cstdio>, whose FILE it uses
#include <png.h>

namespace pvcap::testing {

namespace {

struct JpegErrors {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
};

void jpeg_failed(j_common_ptr info) { std::longjmp(reinterpret_cast<JpegErrors*>(info->err)->jump, 1); }

// Decompresses into `out` (the caller's, sized here once the header is read): no C++ object lives in
// this frame across the setjmp that libjpeg's errors jump back to. False on a damaged file.
bool decompress(const std::vector<unsigned char>& bytes, bool grey, jpeg_decompress_struct& info, JpegErrors& errors,
                cv::Mat& out) {
  info.err = jpeg_std_error(&errors.mgr);
  errors.mgr.error_exit = jpeg_failed;
  if (setjmp(errors.jump)) return false;
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, bytes.data(), static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&info, TRUE);
  info.out_color_space = grey ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_start_decompress(&info);
  out.create(int(info.output_height), int(info.output_width), grey ? CV_8UC1 : CV_8UC3);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = out.ptr(int(info.output_scanline));
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  return true;
}

cv::Mat read_jpeg(const std::filesystem::path& file, bool grey) {
  std::ifstream in(file, std::ios::binary);
  const std::vector<unsigned char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (bytes.empty()) return {};
  jpeg_decompress_struct info{};
  JpegErrors errors{};
  cv::Mat out;
  const bool ok = decompress(bytes, grey, info, errors, out);
  jpeg_destroy_decompress(&info);
  return ok ? out : cv::Mat();
}

cv::Mat read_png(const std::filesystem::path& file, bool grey) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, file.c_str())) return {};
  image.format = grey ? PNG_FORMAT_GRAY : PNG_FORMAT_BGR;
  cv::Mat out(int(image.height), int(image.width), grey ? CV_8UC1 : CV_8UC3);
  if (!png_image_finish_read(&image, nullptr, out.data, png_int_32(out.step[0]), nullptr)) {
    png_image_free(&image);
    return {};
  }
  return out;
}

}  // namespace

cv::Mat read_picture(const std::filesystem::path& file, bool grey) {
  const std::string ext = file.extension().string();
  if (ext == ".jpg" || ext == ".jpeg") return read_jpeg(file, grey);
  if (ext == ".png") return read_png(file, grey);
  return {};
}

}  // namespace pvcap::testing
