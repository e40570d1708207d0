#include "common/dataset.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "common/path_check.h"
#include "common/text.h"

namespace rrslam {
namespace fs = std::filesystem;

std::vector<std::pair<size_t, size_t>> AssociateTimestamps(const std::vector<double>& a,
                                                           const std::vector<double>& b,
                                                           double max_difference, double offset) {
  // Candidates inside the window; b is scanned in sorted order so each a only
  // visits the b stamps within max_difference (same result as all pairs).
  std::vector<size_t> b_order(b.size());
  for (size_t j = 0; j < b.size(); ++j) b_order[j] = j;
  std::sort(b_order.begin(), b_order.end(), [&](size_t x, size_t y) { return b[x] < b[y]; });
  std::vector<double> b_sorted(b.size());
  for (size_t k = 0; k < b.size(); ++k) b_sorted[k] = b[b_order[k]] + offset;

  std::vector<std::tuple<double, double, double, size_t, size_t>> candidates;
  for (size_t i = 0; i < a.size(); ++i) {
    auto lo = std::lower_bound(b_sorted.begin(), b_sorted.end(), a[i] - max_difference);
    for (auto it = lo; it != b_sorted.end() && *it <= a[i] + max_difference; ++it) {
      const double diff = std::fabs(a[i] - *it);
      if (diff < max_difference) {
        const size_t j = b_order[it - b_sorted.begin()];
        candidates.emplace_back(diff, a[i], b[j], i, j);
      }
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> used_a(a.size(), false), used_b(b.size(), false);
  std::vector<std::pair<size_t, size_t>> matches;
  for (const auto& [diff, ta, tb, i, j] : candidates) {
    if (used_a[i] || used_b[j]) continue;
    used_a[i] = used_b[j] = true;
    matches.emplace_back(i, j);
  }
  std::sort(matches.begin(), matches.end(), [&](const auto& x, const auto& y) {
    return std::tie(a[x.first], x.first) < std::tie(a[y.first], y.first);
  });
  return matches;
}

std::vector<std::pair<double, std::string>> ReadTimestampList(const fs::path& path) {
  return ParseTimestampList(ReadFileToString(path), path.string());
}

std::vector<std::pair<double, std::string>> ParseTimestampList(std::string_view text,
                                                               const std::string& source) {
  std::vector<std::pair<double, std::string>> list;
  ForEachDataLine(text, source, [&](const std::vector<std::string_view>& fields, int line) {
    if (fields.size() < 2) {
      throw DataError(source + " line " + std::to_string(line) + ": expected 'timestamp filename'");
    }
    list.emplace_back(ParseTimestamp(fields[0], source, line), std::string(fields[1]));
  });
  return list;
}

std::vector<RgbdFrameRef> ParseAssociations(std::string_view text, const fs::path& dir,
                                            const std::string& source) {
  std::vector<RgbdFrameRef> frames;
  ForEachDataLine(text, source, [&](const std::vector<std::string_view>& fields, int line) {
    if (fields.size() < 4) {
      throw DataError(source + " line " + std::to_string(line) +
                      ": expected 'rgb_timestamp rgb_path depth_timestamp depth_path'");
    }
    RgbdFrameRef f;
    f.rgb_timestamp = ParseTimestamp(fields[0], source, line);
    f.rgb_path = dir / std::string(fields[1]);
    f.depth_timestamp = ParseTimestamp(fields[2], source, line);
    f.depth_path = dir / std::string(fields[3]);
    frames.push_back(std::move(f));
  });
  return frames;
}

RgbdSequence RgbdSequence::Open(const fs::path& dir, const SequenceOptions& options) {
  std::error_code ec;
  RequireFolder(dir, "sequence folder");
  RgbdSequence seq;
  seq.dir_ = dir;
  seq.max_image_size_ = options.max_image_size;
  fs::path associations = options.associations;
  if (!associations.empty() && associations.is_relative() && !fs::exists(associations, ec)) {
    associations = dir / associations;
  }
  const fs::path rgb_list = dir / "rgb.txt";
  const fs::path depth_list = dir / "depth.txt";
  if (associations.empty() && !(fs::exists(rgb_list, ec) && fs::exists(depth_list, ec)) &&
      fs::exists(dir / "associations.txt", ec)) {
    associations = dir / "associations.txt";
  }

  if (!associations.empty()) {
    if (!fs::is_regular_file(associations, ec)) {
      throw NoInputError(associations.string() + ": no such associations file");
    }
    seq.frames_ = ParseAssociations(ReadFileToString(associations), dir, associations.string());
    if (seq.frames_.empty()) throw DataError(associations.string() + ": lists no frames");
  } else {
    if (!fs::is_regular_file(rgb_list, ec)) {
      throw NoInputError(rgb_list.string() + ": missing (not a TUM RGB-D sequence folder?)");
    }
    if (!fs::is_regular_file(depth_list, ec)) throw NoInputError(depth_list.string() + ": missing");
    const auto rgb = ReadTimestampList(rgb_list);
    const auto depth = ReadTimestampList(depth_list);
    if (rgb.empty()) throw DataError(rgb_list.string() + ": lists no images");
    if (depth.empty()) throw DataError(depth_list.string() + ": lists no images");
    std::vector<double> rgb_stamps, depth_stamps;
    for (const auto& entry : rgb) rgb_stamps.push_back(entry.first);
    for (const auto& entry : depth) depth_stamps.push_back(entry.first);
    for (const auto& [i, j] :
         AssociateTimestamps(rgb_stamps, depth_stamps, options.max_time_difference)) {
      RgbdFrameRef f;
      f.rgb_timestamp = rgb[i].first;
      f.rgb_path = dir / rgb[i].second;
      f.depth_timestamp = depth[j].first;
      f.depth_path = dir / depth[j].second;
      seq.frames_.push_back(std::move(f));
    }
    if (seq.frames_.empty()) {
      throw DataError(dir.string() + ": no RGB and depth timestamps within " +
                      std::to_string(options.max_time_difference) + " s of each other");
    }
  }
  for (const RgbdFrameRef& f : seq.frames_) {
    for (const fs::path& image : {f.rgb_path, f.depth_path}) {
      const std::string why = WhyNotAFile(image);
      if (!why.empty()) throw DataError(image.string() + ": listed image " + why);
    }
  }
  const fs::path gt = dir / "groundtruth.txt";
  if (fs::is_regular_file(gt, ec)) seq.groundtruth_ = ReadTumTrajectory(gt);
  return seq;
}

cv::Mat LoadColorImage(const fs::path& path, const ImageSizeLimit& limit) {
  return ReadImage(path, ImageReadMode::kColor, limit);
}

cv::Mat LoadGrayImage(const fs::path& path, const ImageSizeLimit& limit) {
  return ReadImage(path, ImageReadMode::kGray, limit);
}

cv::Mat LoadDepthImage(const fs::path& path, const ImageSizeLimit& limit) {
  const cv::Mat depth = ReadImage(path, ImageReadMode::kUnchanged, limit);
  if (depth.type() != CV_16UC1) {
    throw DataError(path.string() + ": depth must be 16-bit single-channel, got " +
                    std::to_string(8 * depth.elemSize1()) + "-bit " +
                    std::to_string(depth.channels()) + "-channel");
  }
  return depth;
}

void CheckSameSize(const cv::Mat& rgb, const cv::Mat& depth, const fs::path& depth_path) {
  if (rgb.size() != depth.size()) {
    throw DataError(depth_path.string() + ": depth is " + std::to_string(depth.cols) + "x" +
                    std::to_string(depth.rows) + " but the colour image is " +
                    std::to_string(rgb.cols) + "x" + std::to_string(rgb.rows));
  }
}

cv::Mat RgbdSequence::LoadColor(size_t i) const {
  return LoadColorImage(frame(i).rgb_path, max_image_size_);
}
cv::Mat RgbdSequence::LoadGray(size_t i) const {
  return LoadGrayImage(frame(i).rgb_path, max_image_size_);
}
cv::Mat RgbdSequence::LoadDepthRaw(size_t i) const {
  return LoadDepthImage(frame(i).depth_path, max_image_size_);
}

cv::Mat RgbdSequence::LoadDepthMetres(size_t i, double depth_map_factor) const {
  cv::Mat metres;
  LoadDepthRaw(i).convertTo(metres, CV_32F, 1.0 / depth_map_factor);
  return metres;
}

}  // namespace rrslam
