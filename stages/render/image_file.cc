#include "stages/render/image_file.h"

#include <OpenImageIO/imageio.h>

#include <opencv2/imgproc.hpp>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/path_check.h"

namespace rrslam {

void WritePicture(const std::filesystem::path& path, const cv::Mat& image,
                  const ImageMetadata& metadata) {
  if (image.empty() || image.depth() != CV_8U || image.channels() == 2 || image.channels() > 4) {
    throw CantCreateError(path.string() + ": cannot write: not an 8-bit grey, BGR or BGRA image");
  }
  cv::Mat rgb;
  if (image.channels() == 3) {
    cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, rgb, cv::COLOR_BGRA2RGBA);
  } else {
    rgb = image.isContinuous() ? image : image.clone();
  }
  AtomicOutput output(path);
  // The temporary name ends in ".tmp": name the format instead of letting
  // OpenImageIO guess it from the extension.
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create("png");
  if (!out) throw CantCreateError(path.string() + ": cannot write: no PNG writer in OpenImageIO");
  OIIO::ImageSpec spec(rgb.cols, rgb.rows, rgb.channels(), OIIO::TypeDesc::UINT8);
  if (!metadata.software.empty()) spec.attribute("Software", metadata.software);
  if (!metadata.description.empty()) spec.attribute("ImageDescription", metadata.description);
  for (const auto& [key, value] : metadata.attributes) spec.attribute(key, value);
  spec.attribute("png:compressionLevel", 6);
  const std::string temp = output.temp_path().string();
  if (!out->open(temp, spec) || !out->write_image(OIIO::TypeDesc::UINT8, rgb.data) ||
      !out->close()) {
    throw CantCreateError(path.string() + ": cannot write: " + out->geterror());
  }
  output.Commit();
}

std::vector<std::pair<std::string, std::string>> ReadPictureMetadata(
    const std::filesystem::path& path) {
  RequireFile(path, "file");
  std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path.string());
  if (!in) throw DataError(path.string() + ": not a readable image: " + OIIO::geterror());
  std::vector<std::pair<std::string, std::string>> result;
  for (const OIIO::ParamValue& value : in->spec().extra_attribs) {
    result.emplace_back(value.name().string(), value.get_string());
  }
  in->close();
  return result;
}

}  // namespace rrslam
