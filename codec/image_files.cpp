#include "codec/image_files.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <jpeglib.h>
#include <png.h>

namespace pvcap {

namespace {

std::string describe(const cv::Mat& image) {
  return fmt::format("{}x{}, {} channel(s) of {} bits", image.cols, image.rows, image.channels(),
                     image.depth() == CV_8U ? 8 : int(image.elemSize1() * 8));
}

// One compression's state, owned by the caller of compress_jpeg: libjpeg reports errors by calling
// error_exit, which must not return; it jumps back into compress_jpeg, whose own frame holds no
// object with a destructor and no local it changes after setjmp.
struct JpegJob {
  jpeg_compress_struct info{};
  jpeg_error_mgr errors{};
  std::jmp_buf jump{};
  char message[JMSG_LENGTH_MAX] = {};
  unsigned char* out = nullptr;  // jpeg_mem_dest's buffer: the caller's, or malloc'd by libjpeg when it was too small
  unsigned long size = 0;        // in: the caller's buffer's size; out: the JPEG's
};

void on_jpeg_error(j_common_ptr info) {
  auto* job = reinterpret_cast<JpegJob*>(info->client_data);
  (*info->err->format_message)(info, job->message);
  std::longjmp(job->jump, 1);
}

void on_jpeg_warning(j_common_ptr) {}  // libjpeg's warnings would go to stderr; none matters here

bool compress_jpeg(JpegJob& job, const cv::Mat& image, int quality) {
  job.info.err = jpeg_std_error(&job.errors);
  job.errors.error_exit = on_jpeg_error;
  job.errors.output_message = on_jpeg_warning;
  job.info.client_data = &job;
  if (setjmp(job.jump)) {
    jpeg_destroy_compress(&job.info);
    return false;
  }
  jpeg_create_compress(&job.info);
  jpeg_mem_dest(&job.info, &job.out, &job.size);
  job.info.image_width = JDIMENSION(image.cols);
  job.info.image_height = JDIMENSION(image.rows);
  job.info.input_components = image.channels();
  job.info.in_color_space = image.channels() == 3 ? JCS_EXT_BGR : JCS_GRAYSCALE;
  jpeg_set_defaults(&job.info);  // YCbCr, 4:2:0, the integer DCT: what OpenCV's imencode asks for
  jpeg_set_quality(&job.info, quality, TRUE);
  jpeg_start_compress(&job.info, TRUE);
  while (job.info.next_scanline < job.info.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(image.ptr<JSAMPLE>(int(job.info.next_scanline)));
    jpeg_write_scanlines(&job.info, &row, 1);
  }
  jpeg_finish_compress(&job.info);
  jpeg_destroy_compress(&job.info);
  return true;
}

}  // namespace

Result<std::size_t> encode_jpeg_into(const cv::Mat& image, int quality, std::vector<std::uint8_t>& buffer) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    return Error{fmt::format("JPEG: cannot encode a picture of {} (8-bit grey or BGR only)", describe(image))};
  // Half a byte per sample and 64 KiB: three times a noisy 1080p picture's JPEG at quality 95 (0.49 MB),
  // so libjpeg writes into the buffer as it is (it takes memory of its own, copied back below, only
  // when a picture outgrows it).
  const std::size_t room = std::max<std::size_t>(image.total() * image.channels() / 2 + 65536, 1 << 16);
  if (buffer.size() < room) buffer.resize(room);
  JpegJob job;
  job.out = buffer.data();
  job.size = buffer.size();
  const bool ok = compress_jpeg(job, image, std::clamp(quality, 1, 100));
  const bool own = job.out != buffer.data();  // libjpeg ran out of the buffer and took memory of its own
  std::size_t size = 0;
  if (ok) {
    size = job.size;
    if (own) buffer.assign(job.out, job.out + job.size);
  }
  if (own) std::free(job.out);
  if (!ok) return Error{fmt::format("JPEG: {}", job.message)};
  return size;
}

Result<std::vector<std::uint8_t>> encode_jpeg(const cv::Mat& image, int quality) {
  std::vector<std::uint8_t> bytes;
  auto size = encode_jpeg_into(image, quality, bytes);
  if (!size) return size.error();
  bytes.resize(size.value());
  return bytes;
}

Result<std::vector<std::uint8_t>> encode_png(const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U || image.channels() == 2 || image.channels() > 4)
    return Error{fmt::format("PNG: cannot encode a picture of {} (8-bit grey, BGR or BGRA only)", describe(image))};
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = png_uint_32(image.cols);
  png.height = png_uint_32(image.rows);
  png.format = image.channels() == 1 ? PNG_FORMAT_GRAY : image.channels() == 3 ? PNG_FORMAT_BGR : PNG_FORMAT_BGRA;
  const auto stride = png_int_32(image.step[0]);
  png_alloc_size_t size = 0;
  // The simplified API: no longjmp reaches this code; a failure is a 0 and png.message.
  if (!png_image_write_to_memory(&png, nullptr, &size, 0, image.data, stride, nullptr))
    return Error{fmt::format("PNG: {}", png.message)};
  std::vector<std::uint8_t> bytes(size);
  if (!png_image_write_to_memory(&png, bytes.data(), &size, 0, image.data, stride, nullptr))
    return Error{fmt::format("PNG: {}", png.message)};
  bytes.resize(size);
  return bytes;
}

Status write_image(const std::filesystem::path& file, const cv::Mat& image) {
  std::string ext = file.extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  Result<std::vector<std::uint8_t>> bytes = Error{""};
  if (ext == ".png")
    bytes = encode_png(image);
  else if (ext == ".jpg" || ext == ".jpeg")
    bytes = encode_jpeg(image, 95);
  else
    return Error{fmt::format("{}: a picture is written as .png or .jpg", file.string())};
  if (!bytes) return Error{fmt::format("{}: {}", file.string(), bytes.error().message)};
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.value().data()), std::streamsize(bytes.value().size()));
  if (!out.flush()) return Error{fmt::format("cannot write {}: {}", file.string(), std::strerror(errno))};
  return {};
}

}  // namespace pvcap
