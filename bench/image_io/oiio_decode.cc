#include "bench/image_io/oiio_decode.h"

#include <OpenImageIO/imageio.h>

#include <memory>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace rrslam::bench {

cv::Mat ReadImageOiio(const std::filesystem::path& path, OiioRead read) {
  // OIIO premultiplies colour by alpha unless told not to; ReadImage keeps
  // the stored values.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path.string(), &config);
  if (!in) throw std::runtime_error(path.string() + ": " + OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  const int channels = spec.nchannels;
  const bool wide = spec.format == OIIO::TypeDesc::UINT16;
  if (spec.format != OIIO::TypeDesc::UINT8 && !wide) {
    throw std::runtime_error(path.string() + ": " + spec.format.c_str() + " samples");
  }
  if (channels != 1 && channels != 3 && channels != 4) {
    throw std::runtime_error(path.string() + ": " + std::to_string(channels) + " channels");
  }
  if (wide && channels != 1) {
    throw std::runtime_error(path.string() + ": 16-bit colour is not read by ReadImage");
  }
  cv::Mat image(spec.height, spec.width, CV_MAKETYPE(wide ? CV_16U : CV_8U, channels));
  const bool ok = read == OiioRead::kNativeScanlines
                      ? in->read_native_scanlines(0, 0, 0, spec.height, 0, 0, channels, image.data)
                      : in->read_image(0, 0, 0, channels, spec.format, image.data);
  if (!ok) throw std::runtime_error(path.string() + ": " + in->geterror());
  in->close();
  // OIIO gives RGB(A); ReadImage and OpenCV give BGR(A). Swapped in place.
  if (channels == 3) cv::cvtColor(image, image, cv::COLOR_RGB2BGR);
  if (channels == 4) cv::cvtColor(image, image, cv::COLOR_RGBA2BGRA);
  return image;
}

std::string OiioVersion() {
  const int v = OIIO::openimageio_version();  // 10000 major + 100 minor + patch.
  return std::to_string(v / 10000) + "." + std::to_string(v / 100 % 100) + "." +
         std::to_string(v % 100);
}

}  // namespace rrslam::bench
