#include "stages/extract/orb_extractor.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#if defined(__SSE4_1__)
#include <smmintrin.h>
#endif

#include "common/worker_pool.h"
#include "stages/extract/fast_detector.h"
#include "stages/extract/orb_pattern.h"

namespace rrslam {

// Node of the distribution quadtree: a box [x0, x1) x [y0, y1) and the
// corners inside it, as the range [begin, end) of an index array that the
// splits partition in place (no allocation per node). Not file-local: the
// extractor's work buffers (LevelWork, held by OrbExtractor::Impl) hold them.
struct QuadNode {
  float x0, y0, x1, y1;
  uint32_t begin, end;
  uint32_t count() const { return end - begin; }
  // A box under half a pixel on both sides holds at most one integer pixel,
  // so splitting it further cannot separate anything.
  bool Splittable() const { return count() > 1 && (x1 - x0 > 0.5f || y1 - y0 > 0.5f); }
};

namespace {

// Splits `node` into its four quadrants (partitioning its index range) and
// appends the non-empty ones to `out`.
void SplitNode(const QuadNode& node, const std::vector<FastCorner>& corners, uint32_t* index,
               std::vector<QuadNode>* out) {
  const float xm = 0.5f * (node.x0 + node.x1);
  const float ym = 0.5f * (node.y0 + node.y1);
  auto is_top = [&](uint32_t i) { return corners[i].y < ym; };
  auto is_left = [&](uint32_t i) { return corners[i].x < xm; };
  uint32_t* const begin = index + node.begin;
  uint32_t* const end = index + node.end;
  uint32_t* const mid_y = std::partition(begin, end, is_top);
  uint32_t* const mid_top = std::partition(begin, mid_y, is_left);
  uint32_t* const mid_bottom = std::partition(mid_y, end, is_left);
  auto offset = [&](const uint32_t* p) { return static_cast<uint32_t>(p - index); };
  const QuadNode children[4] = {
      {node.x0, node.y0, xm, ym, node.begin, offset(mid_top)},
      {xm, node.y0, node.x1, ym, offset(mid_top), offset(mid_y)},
      {node.x0, ym, xm, node.y1, offset(mid_y), offset(mid_bottom)},
      {xm, ym, node.x1, node.y1, offset(mid_bottom), node.end},
  };
  for (const QuadNode& child : children) {
    if (child.count() > 0) out->push_back(child);
  }
}

// Chooses up to `wanted` corners spread over the box [x0, x1) x [y0, y1) (the
// quadtree of ORB-SLAM2's DistributeOctTree, with a deterministic order) and
// returns their indices into `corners`.
void DistributeCorners(const std::vector<FastCorner>& corners, float x0, float y0, float x1,
                       float y1, int wanted, std::vector<uint32_t>* index,
                       std::vector<QuadNode>* nodes, std::vector<QuadNode>* scratch,
                       std::vector<uint32_t>* selected) {
  selected->clear();
  if (corners.empty() || wanted <= 0) return;
  const size_t target = static_cast<size_t>(wanted);
  index->resize(corners.size());
  for (uint32_t i = 0; i < corners.size(); ++i) (*index)[i] = i;

  // Root boxes: square-ish columns, as many as the aspect ratio (one for
  // 4:3); corners are bucketed by column, keeping their raster order.
  const int n_roots = std::max(1, static_cast<int>(std::lround((x1 - x0) / (y1 - y0))));
  const float root_width = (x1 - x0) / n_roots;
  auto root_of = [&](uint32_t i) {
    return std::min(n_roots - 1, static_cast<int>((corners[i].x - x0) / root_width));
  };
  std::stable_sort(index->begin(), index->end(),
                   [&](uint32_t a, uint32_t b) { return root_of(a) < root_of(b); });
  nodes->clear();
  for (uint32_t begin = 0, end = 0; begin < index->size(); begin = end) {
    const int r = root_of((*index)[begin]);
    while (end < index->size() && root_of((*index)[end]) == r) ++end;
    const float bx0 = x0 + r * root_width;
    nodes->push_back({bx0, y0, r + 1 == n_roots ? x1 : bx0 + root_width, y1, begin, end});
  }

  // Breadth-first passes: every splittable node is split while a whole pass
  // cannot overshoot the target (each split adds at most three nodes).
  while (nodes->size() < target) {
    int splittable = 0;
    for (const QuadNode& n : *nodes) splittable += n.Splittable() ? 1 : 0;
    if (splittable == 0) break;
    if (nodes->size() + 3 * static_cast<size_t>(splittable) > target) {
      // Final refinement: split the most populated nodes first (ties in node
      // order) and stop as soon as the target is reached.
      std::vector<uint32_t> order;
      while (nodes->size() < target) {
        order.clear();
        for (uint32_t i = 0; i < nodes->size(); ++i) {
          if ((*nodes)[i].Splittable()) order.push_back(i);
        }
        if (order.empty()) break;
        std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
          return (*nodes)[a].count() > (*nodes)[b].count();
        });
        // A split node is replaced by its first child and the others are
        // appended, so the indices in `order` stay valid during the round.
        for (uint32_t i : order) {
          const QuadNode parent = (*nodes)[i];
          scratch->clear();
          SplitNode(parent, corners, index->data(), scratch);
          (*nodes)[i] = scratch->front();
          nodes->insert(nodes->end(), scratch->begin() + 1, scratch->end());
          if (nodes->size() >= target) break;
        }
      }
      break;
    }
    scratch->clear();
    for (const QuadNode& n : *nodes) {
      if (n.Splittable()) {
        SplitNode(n, corners, index->data(), scratch);
      } else {
        scratch->push_back(n);
      }
    }
    nodes->swap(*scratch);
  }

  // The strongest corner of each node; ties go to the earlier corner.
  for (const QuadNode& n : *nodes) {
    uint32_t best = (*index)[n.begin];
    for (uint32_t k = n.begin + 1; k < n.end; ++k) {
      const uint32_t c = (*index)[k];
      if (corners[c].score > corners[best].score ||
          (corners[c].score == corners[best].score && c < best)) {
        best = c;
      }
    }
    selected->push_back(best);
  }
  // The last refinement round may overshoot by up to three nodes: keep the
  // strongest `wanted`.
  if (selected->size() > target) {
    std::sort(selected->begin(), selected->end(), [&](uint32_t a, uint32_t b) {
      return corners[a].score != corners[b].score ? corners[a].score > corners[b].score : a < b;
    });
    selected->resize(target);
  }
}

// Half-widths of the rows of the orientation disc: the pixels (u, v) with
// u^2 + v^2 <= r^2 + r, i.e. inside a circle of radius r + 1/2. The disc is
// symmetric under 90-degree rotations and reflections, so a rotated image
// gives exactly rotated moments.
std::vector<int> DiscHalfWidths(int radius) {
  std::vector<int> half_width(radius + 1);
  for (int v = 0; v <= radius; ++v) {
    int u = 0;
    while ((u + 1) * (u + 1) + v * v <= radius * radius + radius) ++u;
    half_width[v] = u;
  }
  return half_width;
}

// Orientation in degrees [0, 360) of the intensity centroid of the disc
// around (x, y): atan2(m01, m10) (Rosin 1999; x right, y down).
float IntensityCentroidAngle(const cv::Mat& image, int x, int y,
                             const std::vector<int>& half_width) {
  const int radius = static_cast<int>(half_width.size()) - 1;
  const uint8_t* center = image.ptr<uint8_t>(y) + x;
  const ptrdiff_t step = static_cast<ptrdiff_t>(image.step1());
  int m10 = 0;
  int m01 = 0;
  for (int u = -radius; u <= radius; ++u) m10 += u * center[u];
  // Rows +v and -v together: their sum feeds m10, their difference m01.
  for (int v = 1; v <= radius; ++v) {
    const uint8_t* below = center + v * step;
    const uint8_t* above = center - v * step;
    const int w = half_width[v];
    int row_difference = 0;
    for (int u = -w; u <= w; ++u) {
      const int b = below[u];
      const int a = above[u];
      row_difference += b - a;
      m10 += u * (b + a);
    }
    m01 += v * row_difference;
  }
  float degrees = static_cast<float>(
      std::atan2(static_cast<double>(m01), static_cast<double>(m10)) * (180.0 / std::numbers::pi));
  if (degrees < 0) degrees += 360.0f;
  if (degrees >= 360.0f) degrees = 0.0f;
  return degrees;
}

// The pattern as float columns, for rotating four test points at a time.
struct PatternColumns {
  alignas(16) float x1[kOrbPatternTests];
  alignas(16) float y1[kOrbPatternTests];
  alignas(16) float x2[kOrbPatternTests];
  alignas(16) float y2[kOrbPatternTests];
  PatternColumns() {
    for (int i = 0; i < kOrbPatternTests; ++i) {
      x1[i] = kOrbPattern[i][0];
      y1[i] = kOrbPattern[i][1];
      x2[i] = kOrbPattern[i][2];
      y2[i] = kOrbPattern[i][3];
    }
  }
};
const PatternColumns kPatternColumns;

// Rotated BRIEF at (x, y) of the smoothed level image. A test point (u, v)
// rotated by the angle lands at column round(u cos - v sin) and row
// round(u sin + v cos) (rounding half to even, in both code paths).
void ComputeDescriptor(const cv::Mat& smoothed, int x, int y, float angle_deg,
                       OrbDescriptor* descriptor) {
  const float radians = angle_deg * static_cast<float>(std::numbers::pi / 180.0);
  const float c = std::cos(radians);
  const float s = std::sin(radians);
  const int step = static_cast<int>(smoothed.step1());
  const uint8_t* center = smoothed.ptr<uint8_t>(y) + x;
  const PatternColumns& p = kPatternColumns;
  alignas(16) int first[kOrbPatternTests];
  alignas(16) int second[kOrbPatternTests];
#if defined(__SSE4_1__)
  const __m128 vc = _mm_set1_ps(c);
  const __m128 vs = _mm_set1_ps(s);
  const __m128i vstep = _mm_set1_epi32(step);
  auto offsets = [&](const float* px, const float* py, int i) {
    const __m128 u = _mm_load_ps(px + i);
    const __m128 v = _mm_load_ps(py + i);
    const __m128i row = _mm_cvtps_epi32(_mm_add_ps(_mm_mul_ps(u, vs), _mm_mul_ps(v, vc)));
    const __m128i col = _mm_cvtps_epi32(_mm_sub_ps(_mm_mul_ps(u, vc), _mm_mul_ps(v, vs)));
    return _mm_add_epi32(_mm_mullo_epi32(row, vstep), col);
  };
  for (int i = 0; i < kOrbPatternTests; i += 4) {
    _mm_store_si128(reinterpret_cast<__m128i*>(first + i), offsets(p.x1, p.y1, i));
    _mm_store_si128(reinterpret_cast<__m128i*>(second + i), offsets(p.x2, p.y2, i));
  }
#else
  auto round = [](float v) { return static_cast<int>(std::nearbyint(v)); };
  for (int i = 0; i < kOrbPatternTests; ++i) {
    first[i] = round(p.x1[i] * s + p.y1[i] * c) * step + round(p.x1[i] * c - p.y1[i] * s);
    second[i] = round(p.x2[i] * s + p.y2[i] * c) * step + round(p.x2[i] * c - p.y2[i] * s);
  }
#endif
  for (int byte = 0; byte < 32; ++byte) {
    uint32_t value = 0;
    for (int bit = 0; bit < 8; ++bit) {
      const int i = 8 * byte + bit;
      value |= static_cast<uint32_t>(center[first[i]] < center[second[i]]) << bit;
    }
    descriptor->bytes[byte] = static_cast<uint8_t>(value);
  }
}

}  // namespace

// Work buffers of one pyramid level, reused between images.
struct LevelWork {
  std::vector<uint8_t> score_map;
  std::vector<FastCorner> corners;
  std::vector<int> cell_count;
  std::vector<uint32_t> index;
  std::vector<QuadNode> nodes;
  std::vector<QuadNode> scratch;
  std::vector<uint32_t> selected;
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
};

struct OrbExtractor::Impl {
  std::vector<LevelWork> levels;
  std::vector<int> disc_half_width = DiscHalfWidths(kPatchRadius);
  std::unique_ptr<WorkerPool> pool;
};

namespace {

// FAST corners of `image` in the detection box [x0, x1) x [y0, y1), in raster
// order, into work->corners: in each grid cell of about kFastCellSize px, the
// corners at `threshold`, or those at `fallback_threshold` when the cell has
// none. Each detection is exact on its cell (suppression sees the
// neighbours across cell borders), so the result is that of one detection at
// the fallback threshold filtered per cell (fast_detector.h).
void DetectCorners(const cv::Mat& image, int x0, int y0, int x1, int y1, int threshold,
                   int fallback_threshold, LevelWork* work) {
  const int width = x1 - x0;
  const int height = y1 - y0;
  std::vector<FastCorner>& corners = work->corners;
  DetectFastCorners(image, cv::Rect(x0, y0, width, height), threshold, &corners, &work->score_map);
  if (fallback_threshold >= threshold) return;
  const int n_cols =
      std::max(1, static_cast<int>(std::lround(double(width) / OrbExtractor::kFastCellSize)));
  const int n_rows =
      std::max(1, static_cast<int>(std::lround(double(height) / OrbExtractor::kFastCellSize)));
  // Cell k spans [x0 + ceil(k w / n), x0 + ceil((k + 1) w / n)): the cell of
  // x is (x - x0) n / w.
  auto cell_x = [&](int k) { return x0 + (k * width + n_cols - 1) / n_cols; };
  auto cell_y = [&](int k) { return y0 + (k * height + n_rows - 1) / n_rows; };
  std::vector<int>& count = work->cell_count;
  count.assign(static_cast<size_t>(n_cols) * n_rows, 0);
  for (const FastCorner& c : corners) {
    ++count[static_cast<size_t>((c.y - y0) * n_rows / height) * n_cols +
            (c.x - x0) * n_cols / width];
  }
  const size_t strong = corners.size();
  for (int r = 0; r < n_rows; ++r) {
    // Runs of consecutive empty cells of a row are detected in one box.
    for (int c = 0; c < n_cols;) {
      if (count[static_cast<size_t>(r) * n_cols + c] > 0) {
        ++c;
        continue;
      }
      int end = c + 1;
      while (end < n_cols && count[static_cast<size_t>(r) * n_cols + end] == 0) ++end;
      const cv::Rect run(cell_x(c), cell_y(r), cell_x(end) - cell_x(c), cell_y(r + 1) - cell_y(r));
      DetectFastCorners(image, run, fallback_threshold, &corners, &work->score_map);
      c = end;
    }
  }
  if (corners.size() > strong) {
    std::sort(corners.begin(), corners.end(), [](const FastCorner& a, const FastCorner& b) {
      return a.y != b.y ? a.y < b.y : a.x < b.x;
    });
  }
}

}  // namespace

OrbExtractor::OrbExtractor(const OrbSettings& settings) : OrbExtractor(settings, 1) {}

OrbExtractor::OrbExtractor(const OrbSettings& settings, int num_threads)
    : settings_(settings), num_threads_(num_threads), impl_(std::make_unique<Impl>()) {
  if (settings.n_features < 1 || settings.n_levels < 1 || settings.n_levels > 16 ||
      !(settings.scale_factor > 1.0 && settings.scale_factor <= 4.0) || settings.ini_th_fast < 1 ||
      settings.ini_th_fast > 255 || settings.min_th_fast < 1 ||
      settings.min_th_fast > settings.ini_th_fast) {
    throw std::invalid_argument(
        "OrbExtractor: invalid ORB settings (nFeatures >= 1, nLevels in [1, 16], scaleFactor "
        "in (1, 4], 1 <= minThFAST <= iniThFAST <= 255)");
  }
  if (num_threads < 1) throw std::invalid_argument("OrbExtractor: num_threads must be >= 1");
  const int n_levels = settings.n_levels;
  scale_factors_.resize(n_levels);
  level_sigma2_.resize(n_levels);
  for (int l = 0; l < n_levels; ++l) {
    scale_factors_[l] = std::pow(settings.scale_factor, l);
    level_sigma2_[l] = scale_factors_[l] * scale_factors_[l];
  }
  // ORB-SLAM2's rule: level l gets a share of the features proportional to
  // its linear scale 1/s^l (not its area): n_l = n_0 r^l with r = 1/s and
  // n_0 = N (1 - r) / (1 - r^L), in single precision and rounded half to even
  // (cvRound) as ORB-SLAM2 computes it; the last level takes the remainder.
  const float ratio = 1.0f / static_cast<float>(settings.scale_factor);
  float wanted = static_cast<float>(settings.n_features) * (1.0f - ratio) /
                 (1.0f - static_cast<float>(std::pow(static_cast<double>(ratio), n_levels)));
  features_per_level_.resize(n_levels);
  int assigned = 0;
  for (int l = 0; l + 1 < n_levels; ++l) {
    features_per_level_[l] = static_cast<int>(std::lrint(wanted));
    assigned += features_per_level_[l];
    wanted *= ratio;
  }
  features_per_level_[n_levels - 1] = std::max(settings.n_features - assigned, 0);

  pyramid_.resize(n_levels);
  blurred_.resize(n_levels);
  impl_->levels.resize(n_levels);
  if (num_threads > 1) impl_->pool = std::make_unique<WorkerPool>(num_threads);
}

OrbExtractor::~OrbExtractor() = default;
OrbExtractor::OrbExtractor(OrbExtractor&&) noexcept = default;
OrbExtractor& OrbExtractor::operator=(OrbExtractor&&) noexcept = default;

void OrbExtractor::Extract(const cv::Mat& gray, std::vector<Keypoint>* keypoints,
                           std::vector<OrbDescriptor>* descriptors) {
  if (gray.type() != CV_8UC1) {
    throw std::invalid_argument("OrbExtractor::Extract: image must be 8-bit grayscale (CV_8UC1)");
  }
  keypoints->clear();
  descriptors->clear();
  const int n_levels = settings_.n_levels;
  // Pyramid: each level from the previous one (bilinear), as ORB-SLAM2; the
  // cascade low-passes the image more than one large bilinear step would.
  pyramid_[0] = gray;
  auto build_level = [&](int l) {
    const cv::Size size(static_cast<int>(std::lround(gray.cols / scale_factors_[l])),
                        static_cast<int>(std::lround(gray.rows / scale_factors_[l])));
    if (pyramid_[l - 1].empty() || size.width < 1 || size.height < 1) {
      pyramid_[l].release();
    } else {
      cv::resize(pyramid_[l - 1], pyramid_[l], size, 0, 0, cv::INTER_LINEAR);
    }
  };

  auto process_level = [&](int l) {
    LevelWork& work = impl_->levels[l];
    work.keypoints.clear();
    work.descriptors.clear();
    work.corners.clear();
    const cv::Mat& image = pyramid_[l];
    const int x0 = kEdgeThreshold, y0 = kEdgeThreshold;
    const int x1 = image.cols - kEdgeThreshold, y1 = image.rows - kEdgeThreshold;
    if (image.empty() || x1 <= x0 || y1 <= y0 || features_per_level_[l] == 0) {
      blurred_[l].release();
      return;
    }
    DetectCorners(image, x0, y0, x1, y1, settings_.ini_th_fast, settings_.min_th_fast, &work);
    DistributeCorners(work.corners, static_cast<float>(x0), static_cast<float>(y0),
                      static_cast<float>(x1), static_cast<float>(y1), features_per_level_[l],
                      &work.index, &work.nodes, &work.scratch, &work.selected);
    std::sort(work.selected.begin(), work.selected.end(), [&](uint32_t a, uint32_t b) {
      const FastCorner& ca = work.corners[a];
      const FastCorner& cb = work.corners[b];
      return ca.y != cb.y ? ca.y < cb.y : ca.x < cb.x;
    });
    // Level pixel centres map to level 0 as cv::resize samples them.
    const float sx = static_cast<float>(gray.cols) / image.cols;
    const float sy = static_cast<float>(gray.rows) / image.rows;
    work.keypoints.resize(work.selected.size());
    for (size_t k = 0; k < work.selected.size(); ++k) {
      const FastCorner& corner = work.corners[work.selected[k]];
      Keypoint& kp = work.keypoints[k];
      kp.pixel =
          l == 0 ? Eigen::Vector2f(static_cast<float>(corner.x), static_cast<float>(corner.y))
                 : Eigen::Vector2f((corner.x + 0.5f) * sx - 0.5f, (corner.y + 0.5f) * sy - 0.5f);
      kp.undistorted = kp.pixel;
      kp.angle_deg = IntensityCentroidAngle(image, corner.x, corner.y, impl_->disc_half_width);
      kp.octave = static_cast<uint8_t>(l);
      kp.response = static_cast<float>(corner.score);
      kp.depth = 0;
    }
    // The 7x7 Gaussian of sigma 2 (ORB-SLAM2's choice) makes the binary tests
    // robust to noise; the detection box keeps every test point inside the
    // image. BORDER_ISOLATED: a view into a larger image gives the same result
    // as its copy.
    cv::GaussianBlur(image, blurred_[l], cv::Size(7, 7), 2.0, 2.0,
                     cv::BORDER_REFLECT_101 | cv::BORDER_ISOLATED);
    work.descriptors.resize(work.selected.size());
    for (size_t k = 0; k < work.selected.size(); ++k) {
      const FastCorner& corner = work.corners[work.selected[k]];
      ComputeDescriptor(blurred_[l], corner.x, corner.y, work.keypoints[k].angle_deg,
                        &work.descriptors[k]);
    }
  };

  if (impl_->pool) {
    // Task 0 builds the pyramid while another thread works on level 0; task
    // 1 + l processes level l, once built. Levels are claimed largest first,
    // which balances two threads to within a few percent (level areas fall by
    // 1/s^2 each).
    // A failed build releases the waiting tasks with kBuildFailed (its
    // exception is rethrown by ParallelFor).
    constexpr int kBuildFailed = 1 << 20;
    std::atomic<int> levels_built{1};
    const std::function<void(size_t)> task = [&](size_t t) {
      if (t == 0) {
        try {
          for (int l = 1; l < n_levels; ++l) {
            build_level(l);
            levels_built.store(l + 1, std::memory_order_release);
            levels_built.notify_all();
          }
        } catch (...) {
          levels_built.store(kBuildFailed, std::memory_order_release);
          levels_built.notify_all();
          throw;
        }
        return;
      }
      const int l = static_cast<int>(t) - 1;
      int built = levels_built.load(std::memory_order_acquire);
      while (built <= l) {
        levels_built.wait(built, std::memory_order_acquire);
        built = levels_built.load(std::memory_order_acquire);
      }
      if (built != kBuildFailed) process_level(l);
    };
    impl_->pool->ParallelFor(static_cast<size_t>(n_levels) + 1, task);
  } else {
    // Each level right after it is built, while it is in cache.
    for (int l = 0; l < n_levels; ++l) {
      if (l > 0) build_level(l);
      process_level(l);
    }
  }

  size_t total = 0;
  for (const LevelWork& work : impl_->levels) total += work.keypoints.size();
  keypoints->reserve(total);
  descriptors->reserve(total);
  for (const LevelWork& work : impl_->levels) {
    keypoints->insert(keypoints->end(), work.keypoints.begin(), work.keypoints.end());
    descriptors->insert(descriptors->end(), work.descriptors.begin(), work.descriptors.end());
  }
}

void FinishKeypoints(const PinholeCamera& camera, const cv::Mat& depth_metres,
                     std::vector<Keypoint>* keypoints) {
  if (!depth_metres.empty() && depth_metres.type() != CV_32FC1) {
    throw std::invalid_argument("FinishKeypoints: depth image must be CV_32FC1 (metres)");
  }
  const bool distorted = !camera.distortion().IsZero();
  for (Keypoint& kp : *keypoints) {
    kp.undistorted = distorted
                         ? Pixel2f(camera.UndistortPixel(kp.pixel.cast<double>()).cast<float>())
                         : kp.pixel;
    kp.depth = 0;
    if (depth_metres.empty()) continue;
    const long u = std::lround(kp.pixel.x());
    const long v = std::lround(kp.pixel.y());
    if (u < 0 || v < 0 || u >= depth_metres.cols || v >= depth_metres.rows) continue;
    const float d = depth_metres.at<float>(static_cast<int>(v), static_cast<int>(u));
    if (std::isfinite(d) && d > 0) kp.depth = d;
  }
}

}  // namespace rrslam
