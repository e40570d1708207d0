#include "common/image_io.h"

// clang-format off
#include <cstdio>   // jpeglib.h needs FILE and size_t first.
#include <jpeglib.h>
// clang-format on
#include <png.h>
#include <setjmp.h>

#include <algorithm>
#include <cstring>
#include <opencv2/imgproc.hpp>

#include "common/atomic_file.h"
#include "common/errors.h"

namespace rrslam {
namespace {

// Throws DataError when a header's size exceeds `limit` (before decoding).
void CheckImageSize(uint64_t width, uint64_t height, const ImageSizeLimit& limit,
                    const std::string& name) {
  const int max_width = limit.MaxWidth(), max_height = limit.MaxHeight();
  if (width <= static_cast<uint64_t>(max_width) && height <= static_cast<uint64_t>(max_height)) {
    return;
  }
  std::string why;
  if (max_width == kMaxImageSide && max_height == kMaxImageSide) {
    why = " (the largest image read: " + std::to_string(kMaxImageSide) + " pixels a side)";
  } else if (!limit.source.empty()) {
    why = " (" + limit.source + ")";
  }
  throw DataError(name + ": image is " + std::to_string(width) + "x" + std::to_string(height) +
                  ", larger than " + std::to_string(max_width) + "x" + std::to_string(max_height) +
                  why);
}

// ---- PNG decoding -----------------------------------------------------------

struct PngReadSource {
  std::span<const uint8_t> bytes;
  size_t offset = 0;
};

void PngReadCallback(png_structp png, png_bytep out, png_size_t length) {
  auto* source = static_cast<PngReadSource*>(png_get_io_ptr(png));
  if (source->offset + length > source->bytes.size()) png_error(png, "truncated file");
  std::memcpy(out, source->bytes.data() + source->offset, length);
  source->offset += length;
}

struct PngErrorState {
  char message[200] = "corrupt PNG";
};

void PngErrorCallback(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof(state->message), "%s", message);
  png_longjmp(png, 1);
}

void PngWarningCallback(png_structp, png_const_charp) {}

// All state of one decode lives here, not in the frame that calls setjmp, so
// nothing the error path touches is clobbered by longjmp.
struct PngDecodeJob {
  PngReadSource source;
  PngErrorState errors;
  png_structp png = nullptr;
  png_infop info = nullptr;
  ImageSizeLimit limit;
  cv::Mat image;
  std::vector<png_bytep> rows;
  bool bad_size = false;
};

bool RunPngDecode(PngDecodeJob* job) {
  if (setjmp(png_jmpbuf(job->png))) return false;
  png_structp png = job->png;
  png_infop info = job->info;
  png_set_read_fn(png, &job->source, PngReadCallback);
  png_read_info(png, info);
  const png_uint_32 width = png_get_image_width(png, info);
  const png_uint_32 height = png_get_image_height(png, info);
  const int bit_depth = png_get_bit_depth(png, info);
  const int color_type = png_get_color_type(png, info);
  if (width == 0 || height == 0 || width > static_cast<png_uint_32>(job->limit.MaxWidth()) ||
      height > static_cast<png_uint_32>(job->limit.MaxHeight())) {
    job->bad_size = true;  // Refused from the header, before anything is allocated.
    return false;
  }
  // Normalize to 8-bit grey/BGR/BGRA or 16-bit grey/BGR(A); no gamma handling,
  // so 16-bit depth values come out exactly as stored.
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (color_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
  if (bit_depth == 16) png_set_swap(png);  // PNG is big-endian; memory is little-endian.
  if (color_type == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_strip_alpha(png);
  png_set_bgr(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  const int channels = png_get_channels(png, info);
  const int depth = png_get_bit_depth(png, info) == 16 ? CV_16U : CV_8U;
  job->image.create(static_cast<int>(height), static_cast<int>(width),
                    CV_MAKETYPE(depth, channels));
  job->rows.resize(height);
  for (png_uint_32 y = 0; y < height; ++y) {
    job->rows[y] = job->image.ptr<png_byte>(static_cast<int>(y));
  }
  png_read_image(png, job->rows.data());
  png_read_end(png, nullptr);
  return true;
}

cv::Mat DecodePng(std::span<const uint8_t> bytes, const std::string& name,
                  const ImageSizeLimit& limit) {
  PngDecodeJob job;
  job.source = {bytes, 0};
  job.limit = limit;
  job.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &job.errors, PngErrorCallback,
                                   PngWarningCallback);
  job.info = job.png != nullptr ? png_create_info_struct(job.png) : nullptr;
  if (job.png == nullptr || job.info == nullptr) {
    png_destroy_read_struct(&job.png, &job.info, nullptr);
    throw std::bad_alloc();
  }
  const bool ok = RunPngDecode(&job);
  uint64_t width = 0, height = 0;
  if (job.bad_size) {
    width = png_get_image_width(job.png, job.info);
    height = png_get_image_height(job.png, job.info);
  }
  png_destroy_read_struct(&job.png, &job.info, nullptr);
  if (job.bad_size) {
    if (width == 0 || height == 0) throw DataError(name + ": unsupported PNG size 0");
    CheckImageSize(width, height, limit, name);
  }
  if (!ok) throw DataError(name + ": cannot decode PNG: " + job.errors.message);
  return job.image;
}

// ---- JPEG decoding ----------------------------------------------------------

struct JpegErrorManager {
  jpeg_error_mgr base;
  jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = "corrupt JPEG";
};

void JpegErrorExit(j_common_ptr cinfo) {
  auto* manager = reinterpret_cast<JpegErrorManager*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, manager->message);
  longjmp(manager->jump, 1);
}

void JpegSilence(j_common_ptr, int) {}

struct JpegDecodeJob {
  jpeg_decompress_struct cinfo;
  JpegErrorManager errors;
  ImageSizeLimit limit;
  cv::Mat image;
  bool bad_size = false;
};

bool RunJpegDecode(JpegDecodeJob* job, std::span<const uint8_t> bytes, bool gray) {
  if (setjmp(job->errors.jump)) return false;
  jpeg_decompress_struct* cinfo = &job->cinfo;
  jpeg_mem_src(cinfo, bytes.data(), static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(cinfo, TRUE);
  if (cinfo->image_width > static_cast<JDIMENSION>(job->limit.MaxWidth()) ||
      cinfo->image_height > static_cast<JDIMENSION>(job->limit.MaxHeight())) {
    job->bad_size = true;  // Refused from the header, before anything is allocated.
    return false;
  }
  // Grey output of a colour JPEG is its luma channel, as cv::IMREAD_GRAYSCALE.
  cinfo->out_color_space = gray ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_start_decompress(cinfo);
  job->image.create(static_cast<int>(cinfo->output_height), static_cast<int>(cinfo->output_width),
                    gray ? CV_8UC1 : CV_8UC3);
  while (cinfo->output_scanline < cinfo->output_height) {
    JSAMPROW row = job->image.ptr<JSAMPLE>(static_cast<int>(cinfo->output_scanline));
    jpeg_read_scanlines(cinfo, &row, 1);
  }
  jpeg_finish_decompress(cinfo);
  return true;
}

cv::Mat DecodeJpeg(std::span<const uint8_t> bytes, bool gray, const std::string& name,
                   const ImageSizeLimit& limit) {
  JpegDecodeJob job;
  job.limit = limit;
  job.cinfo.err = jpeg_std_error(&job.errors.base);
  job.errors.base.error_exit = JpegErrorExit;
  job.errors.base.emit_message = JpegSilence;
  jpeg_create_decompress(&job.cinfo);
  const bool ok = RunJpegDecode(&job, bytes, gray);
  const uint64_t width = job.cinfo.image_width, height = job.cinfo.image_height;
  jpeg_destroy_decompress(&job.cinfo);
  if (job.bad_size) CheckImageSize(width, height, limit, name);
  if (!ok) throw DataError(name + ": cannot decode JPEG: " + job.errors.message);
  return job.image;
}

bool IsPng(std::span<const uint8_t> bytes) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  return bytes.size() >= 8 && std::memcmp(bytes.data(), kSignature, 8) == 0;
}

bool IsJpeg(std::span<const uint8_t> bytes) {
  return bytes.size() >= 3 && bytes[0] == 0xff && bytes[1] == 0xd8 && bytes[2] == 0xff;
}

cv::Mat ConvertForMode(cv::Mat image, ImageReadMode mode, const std::string& name) {
  if (mode == ImageReadMode::kUnchanged) return image;
  if (image.depth() != CV_8U) {
    throw DataError(name + ": expected an 8-bit image, got " +
                    std::to_string(8 * image.elemSize1()) + "-bit");
  }
  cv::Mat out;
  if (mode == ImageReadMode::kColor) {
    if (image.channels() == 3) return image;
    cv::cvtColor(image, out, image.channels() == 1 ? cv::COLOR_GRAY2BGR : cv::COLOR_BGRA2BGR);
  } else {
    if (image.channels() == 1) return image;
    cv::cvtColor(image, out, image.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
  }
  return out;
}

// ---- PNG encoding -----------------------------------------------------------

void PngWriteCallback(png_structp png, png_bytep data, png_size_t length) {
  auto* out = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + length);
}

void PngFlushCallback(png_structp) {}

}  // namespace

cv::Mat DecodeImage(std::span<const uint8_t> bytes, ImageReadMode mode, const std::string& name,
                    const ImageSizeLimit& limit) {
  if (IsPng(bytes)) return ConvertForMode(DecodePng(bytes, name, limit), mode, name);
  if (IsJpeg(bytes)) return DecodeJpeg(bytes, mode == ImageReadMode::kGray, name, limit);
  throw DataError(name + ": not a PNG or JPEG image");
}

cv::Mat ReadImage(const std::filesystem::path& path, ImageReadMode mode,
                  const ImageSizeLimit& limit) {
  const std::string bytes = ReadFileToString(path);
  return DecodeImage({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, mode,
                     path.string(), limit);
}

namespace {

struct PngEncodeJob {
  PngErrorState errors;
  png_structp png = nullptr;
  png_infop info = nullptr;
  std::vector<png_text> chunks;
  std::vector<png_bytep> rows;
  std::vector<uint8_t> out;
};

bool RunPngEncode(PngEncodeJob* job, const cv::Mat& image, int compression) {
  if (setjmp(png_jmpbuf(job->png))) return false;
  png_structp png = job->png;
  png_infop info = job->info;
  png_set_write_fn(png, &job->out, PngWriteCallback, PngFlushCallback);
  png_set_compression_level(png, std::clamp(compression, 0, 9));
  const int color_type = image.channels() == 1   ? PNG_COLOR_TYPE_GRAY
                         : image.channels() == 3 ? PNG_COLOR_TYPE_RGB
                                                 : PNG_COLOR_TYPE_RGBA;
  png_set_IHDR(png, info, image.cols, image.rows, image.depth() == CV_16U ? 16 : 8, color_type,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (!job->chunks.empty()) {
    png_set_text(png, info, job->chunks.data(), static_cast<int>(job->chunks.size()));
  }
  png_write_info(png, info);
  if (image.depth() == CV_16U) png_set_swap(png);
  if (image.channels() >= 3) png_set_bgr(png);
  png_write_image(png, job->rows.data());
  png_write_end(png, nullptr);
  return true;
}

}  // namespace

std::vector<uint8_t> EncodePng(const cv::Mat& image, int compression,
                               const std::vector<std::pair<std::string, std::string>>& text) {
  const int type = image.type();
  if (type != CV_8UC1 && type != CV_8UC3 && type != CV_8UC4 && type != CV_16UC1) {
    throw std::invalid_argument("EncodePng: unsupported image type");
  }
  if (image.empty()) throw std::invalid_argument("EncodePng: empty image");
  PngEncodeJob job;
  job.chunks.resize(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    job.chunks[i].compression = PNG_TEXT_COMPRESSION_NONE;
    job.chunks[i].key = const_cast<char*>(text[i].first.c_str());
    job.chunks[i].text = const_cast<char*>(text[i].second.c_str());
    job.chunks[i].text_length = text[i].second.size();
  }
  job.rows.resize(image.rows);
  for (int y = 0; y < image.rows; ++y) job.rows[y] = const_cast<png_bytep>(image.ptr<png_byte>(y));
  job.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &job.errors, PngErrorCallback,
                                    PngWarningCallback);
  job.info = job.png != nullptr ? png_create_info_struct(job.png) : nullptr;
  if (job.png == nullptr || job.info == nullptr) {
    png_destroy_write_struct(&job.png, &job.info);
    throw std::bad_alloc();
  }
  const bool ok = RunPngEncode(&job, image, compression);
  png_destroy_write_struct(&job.png, &job.info);
  if (!ok) throw std::runtime_error(std::string("EncodePng: ") + job.errors.message);
  return std::move(job.out);
}

void WritePng(const std::filesystem::path& path, const cv::Mat& image, int compression,
              const std::vector<std::pair<std::string, std::string>>& text) {
  const std::vector<uint8_t> bytes = EncodePng(image, compression, text);
  WriteFileAtomically(path, {reinterpret_cast<const char*>(bytes.data()), bytes.size()});
}

}  // namespace rrslam
