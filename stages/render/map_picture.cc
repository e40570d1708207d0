#include "stages/render/map_picture.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "common/chart.h"
#include "common/errors.h"

namespace rrslam {
namespace {

using namespace chart;

// Colours (BGR).
const cv::Scalar kFrustum(190, 100, 20);
const cv::Scalar kLoadedFrustum(150, 150, 150);
const cv::Scalar kTrajectory(40, 40, 40);
const cv::Scalar kSpanningTree(60, 160, 60);
const cv::Scalar kCovisibility(215, 200, 190);
const cv::Scalar kLoopEdge(40, 40, 220);
const cv::Scalar kLoadedPoint(165, 165, 165);
const cv::Scalar kAddedPoint(0, 140, 255);
const cv::Scalar kAxisColours[3] = {cv::Scalar(40, 40, 220), cv::Scalar(40, 170, 40),
                                    cv::Scalar(220, 80, 40)};

Eigen::Vector3d AxisVector(const std::string& name, std::string* canonical) {
  std::string axis = name;
  double sign = 1;
  if (!axis.empty() && (axis[0] == '-' || axis[0] == '+')) {
    sign = axis[0] == '-' ? -1 : 1;
    axis = axis.substr(1);
  }
  if (axis.size() != 1 || axis[0] < 'x' || axis[0] > 'z') {
    throw UsageError("--up = '" + name + "'; must be x, y or z with an optional '-' (e.g. -y)");
  }
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  v[axis[0] - 'x'] = sign;
  *canonical = (sign < 0 ? "-" : "") + axis;
  return v;
}

// "x", "-z", ... of a unit world axis vector.
std::string AxisName(const Eigen::Vector3d& v) {
  for (int k = 0; k < 3; ++k) {
    if (std::fabs(v[k]) > 0.5) return std::string(v[k] < 0 ? "-" : "") + char('x' + k);
  }
  return "?";
}

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

// World corners of a keyframe's frustum at depth `size`: image corners
// (0,0), (w,0), (w,h), (0,h) back-projected.
std::array<Eigen::Vector3d, 4> FrustumCorners(const SceneKeyFrame& kf, const MapCamera& camera,
                                              double size) {
  const double w = camera.width > 0 ? camera.width : 2 * camera.cx;
  const double h = camera.height > 0 ? camera.height : 2 * camera.cy;
  const double fx = camera.fx > 0 ? camera.fx : w, fy = camera.fy > 0 ? camera.fy : w;
  std::array<Eigen::Vector3d, 4> corners;
  const double us[4] = {0, w, w, 0}, vs[4] = {0, 0, h, h};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d c((us[k] - camera.cx) / fx * size, (vs[k] - camera.cy) / fy * size, size);
    corners[k] = kf.T_world_cam * c;
  }
  return corners;
}

std::string FileName(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

}  // namespace

std::string ToString(MapViewKind kind) {
  switch (kind) {
    case MapViewKind::kTop:
      return "top";
    case MapViewKind::kSide:
      return "side";
    case MapViewKind::kFront:
      return "front";
    case MapViewKind::kPerspective:
      return "perspective";
  }
  return "?";
}

std::string ToString(PointColouring colouring) {
  switch (colouring) {
    case PointColouring::kHeight:
      return "height";
    case PointColouring::kObservations:
      return "observations";
    case PointColouring::kAge:
      return "age";
  }
  return "?";
}

bool MapPictureOptions::Check(std::string* why) const {
  if (!CheckChartSize(width_px, height_px, "image", why)) return false;
  if (!(frustum_size >= 0) || !std::isfinite(frustum_size)) {
    *why = fmt::format("frustum size = {} m; must be >= 0 (0 = automatic)", frustum_size);
    return false;
  }
  if (!(point_radius_px >= 0) || point_radius_px > 50) {
    *why = fmt::format("point radius = {} px; must be in [0, 50] (0 = automatic)", point_radius_px);
    return false;
  }
  if (covisibility_min_weight < 0) {
    *why = fmt::format("covisibility minimum weight = {}; must be >= 0", covisibility_min_weight);
    return false;
  }
  try {
    MakeGroundFrame(up);
  } catch (const UsageError& e) {
    *why = e.what();
    return false;
  }
  return true;
}

nlohmann::ordered_json MapPictureOptions::ToJson() const {
  nlohmann::ordered_json json = {{"width_px", width_px},
                                 {"height_px", height_px},
                                 {"color", ToString(colouring)},
                                 {"up", up},
                                 {"frusta", frusta},
                                 {"trajectory", trajectory},
                                 {"spanning_tree", spanning_tree},
                                 {"covisibility", covisibility},
                                 {"covisibility_min_weight", covisibility_min_weight},
                                 {"frustum_size_m", frustum_size}};
  if (viewpoint) {
    json["viewpoint"] = {
        {"x", viewpoint->x}, {"y", viewpoint->y}, {"z", viewpoint->z}, {"f", viewpoint->f}};
  }
  return json;
}

GroundFrame MakeGroundFrame(const std::string& up_name) {
  GroundFrame frame;
  frame.up = AxisVector(up_name, &frame.up_name);
  for (int axis : {2, 0, 1}) {
    if (frame.up[axis] == 0) {
      frame.forward = Eigen::Vector3d::Unit(axis);
      break;
    }
  }
  frame.right = (-frame.up).cross(frame.forward);
  frame.forward_name = AxisName(frame.forward);
  frame.right_name = AxisName(frame.right);
  return frame;
}

std::optional<cv::Point2d> MapViewProjection::Project(const Eigen::Vector3d& world,
                                                      double* depth) const {
  if (kind == MapViewKind::kPerspective) {
    const Eigen::Vector3d p = T_cam_world * world;
    if (depth) *depth = p.z();
    if (p.z() <= 1e-6) return std::nullopt;
    return cv::Point2d(fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy);
  }
  const double u = world.dot(u_direction), v = world.dot(v_direction);
  if (depth) *depth = -world.dot(u_direction.cross(v_direction));
  return cv::Point2d(centre_px.x + (u - centre_u) * pixels_per_metre,
                     centre_px.y - (v - centre_v) * pixels_per_metre);
}

MapPicture RenderMapPicture(const MapScene& scene, MapViewKind kind,
                            const MapPictureOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError("map picture: " + why);
  if (scene.keyframes.empty()) throw DataError(scene.source + ": the map has no keyframes");
  const GroundFrame ground = MakeGroundFrame(options.up);

  MapPicture picture;
  picture.image = cv::Mat(options.height_px, options.width_px, CV_8UC3, kBackground);
  cv::Mat& image = picture.image;
  // A footer row for the colour bar and the scale bar.
  const ChartLayout layout = MakeLayout(image.size(), /*footer=*/true);
  const cv::Rect& area = layout.area;

  // Robust extent of the map: points between the 1st and 99th percentile on
  // each world axis, and every keyframe centre.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> values;
    values.reserve(scene.points.size());
    for (const ScenePoint& p : scene.points) values.push_back(p.position[axis]);
    if (!values.empty()) {
      lo[axis] = Percentile(values, 0.01);
      hi[axis] = Percentile(values, 0.99);
    }
  }
  for (const SceneKeyFrame& kf : scene.keyframes) {
    lo = lo.cwiseMin(kf.centre());
    hi = hi.cwiseMax(kf.centre());
  }
  const double extent = std::max((hi - lo).norm(), 0.1);
  const double frustum = options.frustum_size > 0 ? options.frustum_size : 0.02 * extent;

  // The projection.
  MapViewProjection& projection = picture.projection;
  projection.kind = kind;
  std::string u_label, v_label;
  if (kind == MapViewKind::kPerspective) {
    Eigen::Vector3d eye, target;
    const double aspect_f = options.width_px / 1024.0;
    double f = 500 * aspect_f;
    if (options.viewpoint) {
      eye = Eigen::Vector3d(options.viewpoint->x, options.viewpoint->y, options.viewpoint->z);
      target = Eigen::Vector3d::Zero();
      f = options.viewpoint->f * aspect_f;
    } else {
      // ORB-SLAM2's default direction (above and behind the first camera),
      // at the distance that frames the map's robust extent.
      target = 0.5 * (lo + hi);
      const Eigen::Vector3d direction = (0.7 * ground.up - 1.8 * ground.forward).normalized();
      const double radius = 0.45 * extent;
      const double half_fov = std::atan(0.5 * std::min(area.width, area.height) / f);
      eye = target + direction * (radius / std::tan(half_fov));
    }
    const Eigen::Vector3d z = (target - eye).normalized();
    Eigen::Vector3d x = (-ground.up).cross(z);
    if (x.norm() < 1e-6) x = ground.right;  // Looking straight down or up.
    x.normalize();
    const Eigen::Vector3d y = z.cross(x);
    Eigen::Matrix3d R_cam_world;
    R_cam_world.row(0) = x.transpose();
    R_cam_world.row(1) = y.transpose();
    R_cam_world.row(2) = z.transpose();
    projection.T_cam_world =
        Rigid3d(Eigen::Quaterniond(R_cam_world).normalized(), -(R_cam_world * eye));
    projection.fx = projection.fy = f;
    // Pangolin's principal point in ORB-SLAM2's viewer: (512, 389) of 1024 x 768.
    projection.cx = area.x + area.width * 512.0 / 1024.0;
    projection.cy = area.y + area.height * 389.0 / 768.0;
  } else {
    if (kind == MapViewKind::kTop) {
      projection.u_direction = ground.right;
      projection.v_direction = ground.forward;
      u_label = ground.right_name + " [m]";
      v_label = ground.forward_name + " [m]";
    } else if (kind == MapViewKind::kFront) {
      projection.u_direction = ground.right;
      projection.v_direction = ground.up;
      u_label = ground.right_name + " [m]";
      v_label = ground.up_name + " (up) [m]";
    } else {
      projection.u_direction = ground.forward;
      projection.v_direction = ground.up;
      u_label = ground.forward_name + " [m]";
      v_label = ground.up_name + " (up) [m]";
    }
    // Bounds of the box corners in the view.
    Eigen::Vector2d lo2 = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector2d hi2 = -lo2;
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d p((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                              (corner & 4) ? hi.z() : lo.z());
      const Eigen::Vector2d q(p.dot(projection.u_direction), p.dot(projection.v_direction));
      lo2 = lo2.cwiseMin(q);
      hi2 = hi2.cwiseMax(q);
    }
    const Axes2d axes = FitAxes(lo2, hi2, area);
    projection.centre_u = axes.centre_u;
    projection.centre_v = axes.centre_v;
    projection.pixels_per_metre = axes.pixels_per_u;
    projection.centre_px = axes.centre_px;
    DrawGrid(image, layout, axes);
  }

  // Everything below is drawn on the plot area only.
  cv::Mat canvas = image(area);
  const cv::Point2d origin(area.x, area.y);
  const auto pixel = [&](const Eigen::Vector3d& p) -> std::optional<cv::Point2d> {
    const auto q = projection.Project(p);
    if (!q) return std::nullopt;
    return *q - origin;
  };
  const auto segment = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                           const cv::Scalar& colour, int thickness) {
    const auto pa = pixel(a), pb = pixel(b);
    if (!pa || !pb) return;
    cv::line(canvas, SubPixel(*pa), SubPixel(*pb), colour, thickness, cv::LINE_AA, kShift);
  };
  const double ui = layout.ui;
  const int thin = 1, thick = layout.line_width;

  // Perspective views get a metric grid on the floor (the points' 95th
  // percentile along -up) and a world-axes triad at the origin.
  std::string grid_note;
  if (kind == MapViewKind::kPerspective) {
    std::vector<double> heights;
    for (const ScenePoint& p : scene.points) heights.push_back(p.position.dot(ground.up));
    for (const SceneKeyFrame& kf : scene.keyframes) heights.push_back(kf.centre().dot(ground.up));
    const double floor = Percentile(heights, 0.05);
    const double step = NiceStep(extent / 8);
    const double r0 =
        std::floor(std::min(lo.dot(ground.right), hi.dot(ground.right)) / step) * step;
    const double r1 = std::ceil(std::max(lo.dot(ground.right), hi.dot(ground.right)) / step) * step;
    const double f0 =
        std::floor(std::min(lo.dot(ground.forward), hi.dot(ground.forward)) / step) * step;
    const double f1 =
        std::ceil(std::max(lo.dot(ground.forward), hi.dot(ground.forward)) / step) * step;
    const auto at = [&](double r, double f) {
      return ground.right * r + ground.forward * f + ground.up * floor;
    };
    // Bounded loops (TickValues): none where the step is below the precision
    // of the coordinates or the extent is not finite.
    const std::vector<double> rs = TickValues(r0 - 0.5 * step, r1 + 0.5 * step, step);
    const std::vector<double> fs = TickValues(f0 - 0.5 * step, f1 + 0.5 * step, step);
    for (const double r : rs) segment(at(r, f0), at(r, f1), kGrid, thin);
    for (const double f : fs) segment(at(r0, f), at(r1, f), kGrid, thin);
    if (!rs.empty() && !fs.empty()) grid_note = "floor grid " + TickLabel(step, step) + " m";
    for (int axis = 0; axis < 3; ++axis) {
      const Eigen::Vector3d tip = Eigen::Vector3d::Unit(axis) * (extent * 0.08);
      segment(Eigen::Vector3d::Zero(), tip, kAxisColours[axis], thick);
      if (const auto p = projection.Project(tip * 1.15)) {
        PutText(image, std::string(1, char('x' + axis)), *p, layout.font, 1, 0.5, 0.5,
                kAxisColours[axis]);
        picture.labels.push_back(std::string(1, char('x' + axis)));
      }
    }
  }

  // Graph edges under the points.
  if (options.covisibility) {
    for (const SceneKeyFrame& kf : scene.keyframes) {
      for (const auto& [other, weight] : kf.connections) {
        if (other <= kf.id || weight < options.covisibility_min_weight) continue;
        if (const auto j = scene.FindKeyFrame(other)) {
          segment(kf.centre(), scene.keyframes[*j].centre(), kCovisibility, thin);
        }
      }
    }
  }
  if (options.spanning_tree) {
    for (const SceneKeyFrame& kf : scene.keyframes) {
      if (kf.parent == kNoId) continue;
      if (const auto j = scene.FindKeyFrame(kf.parent)) {
        segment(kf.centre(), scene.keyframes[*j].centre(), kSpanningTree, thin);
      }
    }
  }

  // Points, far ones first.
  std::vector<double> values;
  double value_lo = 0, value_hi = 1;
  std::string bar_caption;
  int colormap = cv::COLORMAP_TURBO;
  size_t loaded_points = 0;
  const bool split_by_age = options.colouring == PointColouring::kAge && scene.has_loaded_part;
  values.reserve(scene.points.size());
  for (const ScenePoint& p : scene.points) {
    switch (options.colouring) {
      case PointColouring::kHeight:
        values.push_back(p.position.dot(ground.up));
        break;
      case PointColouring::kObservations:
        values.push_back(std::log2(std::max(1, p.observations)));
        break;
      case PointColouring::kAge:
        values.push_back(static_cast<double>(p.first_keyframe));
        loaded_points += p.loaded ? 1 : 0;
        break;
    }
  }
  if (!values.empty()) {
    if (options.colouring == PointColouring::kHeight) {
      value_lo = Percentile(values, 0.02);
      value_hi = Percentile(values, 0.98);
      bar_caption = "m height (" + ground.up_name + ")";
    } else if (options.colouring == PointColouring::kObservations) {
      colormap = cv::COLORMAP_VIRIDIS;
      value_lo = 1;  // log2(2): a point has at least 2 observations when made.
      value_hi = std::max(2.0, *std::max_element(values.begin(), values.end()));
      bar_caption = "observations (log scale)";
    } else {
      colormap = cv::COLORMAP_VIRIDIS;
      value_lo = static_cast<double>(scene.keyframes.front().id);
      value_hi = static_cast<double>(scene.keyframes.back().id);
      bar_caption = "first keyframe id";
    }
  }
  if (!(value_hi > value_lo)) value_hi = value_lo + 1;
  std::vector<cv::Scalar> lut(256);
  for (int k = 0; k < 256; ++k) lut[k] = ColormapColour(colormap, k / 255.0);
  struct Dot {
    double depth;
    cv::Point2d pixel;
    cv::Scalar colour;
  };
  std::vector<Dot> dots;
  dots.reserve(scene.points.size());
  std::vector<cv::Point2d> occupied;
  for (size_t i = 0; i < scene.points.size(); ++i) {
    double depth = 0;
    const auto q = projection.Project(scene.points[i].position, &depth);
    if (!q) continue;
    cv::Scalar colour;
    if (split_by_age) {
      colour = scene.points[i].loaded ? kLoadedPoint : kAddedPoint;
    } else {
      const double t = std::clamp((values[i] - value_lo) / (value_hi - value_lo), 0.0, 1.0);
      colour = lut[static_cast<int>(std::lround(t * 255))];
    }
    dots.push_back({depth, *q - origin, colour});
    occupied.push_back(*q);
  }
  std::stable_sort(dots.begin(), dots.end(),
                   [](const Dot& a, const Dot& b) { return a.depth > b.depth; });
  const double radius = options.point_radius_px > 0 ? options.point_radius_px : 1.5 * ui;
  const int radius_fixed = std::max(1, static_cast<int>(std::lround(radius * kSubPixel)));
  for (const Dot& dot : dots) {
    if (dot.pixel.x < -radius || dot.pixel.y < -radius || dot.pixel.x > area.width + radius ||
        dot.pixel.y > area.height + radius) {
      continue;
    }
    cv::circle(canvas, SubPixel(dot.pixel), radius_fixed, dot.colour, -1, cv::LINE_8, kShift);
  }

  // Trajectory, frusta and loop edges over the points.
  if (options.trajectory) {
    std::vector<const SceneKeyFrame*> ordered;
    for (const SceneKeyFrame& kf : scene.keyframes) ordered.push_back(&kf);
    std::stable_sort(
        ordered.begin(), ordered.end(),
        [](const SceneKeyFrame* a, const SceneKeyFrame* b) { return a->timestamp < b->timestamp; });
    for (size_t k = 1; k < ordered.size(); ++k) {
      segment(ordered[k - 1]->centre(), ordered[k]->centre(), kTrajectory, thick);
    }
  }
  if (options.frusta) {
    for (const SceneKeyFrame& kf : scene.keyframes) {
      const cv::Scalar& colour = kf.loaded ? kLoadedFrustum : kFrustum;
      const auto corners = FrustumCorners(kf, scene.camera, frustum);
      for (int k = 0; k < 4; ++k) {
        segment(kf.centre(), corners[k], colour, thin);
        segment(corners[k], corners[(k + 1) % 4], colour, thin);
      }
    }
  }
  size_t loop_edges = 0;
  for (const SceneKeyFrame& kf : scene.keyframes) {
    for (uint64_t other : kf.loop_edges) {
      if (other <= kf.id) continue;
      if (const auto j = scene.FindKeyFrame(other)) {
        segment(kf.centre(), scene.keyframes[*j].centre(), kLoopEdge, thick);
        ++loop_edges;
      }
    }
  }
  for (const SceneKeyFrame& kf : scene.keyframes) {
    if (const auto q = projection.Project(kf.centre())) occupied.push_back(*q);
  }

  // Frame, labels, title, legend, colour bar and scale bar.
  picture.title = fmt::format("{}: {} view, {} points, {} keyframes", FileName(scene.source),
                              ToString(kind), scene.points.size(), scene.keyframes.size());
  if (kind == MapViewKind::kPerspective) {
    cv::rectangle(image, area, kFrame, 1, cv::LINE_8);
    PutText(image, picture.title, {image.cols / 2.0, area.y / 2.0}, layout.title_font,
            layout.title_thickness, 0.5, 0.5);
  } else {
    DrawFrameAndLabels(image, layout, u_label, v_label, picture.title);
    picture.labels.push_back(u_label);
    picture.labels.push_back(v_label);
  }
  std::vector<LegendEntry> legend;
  if (split_by_age) {
    legend.push_back({fmt::format("loaded points ({})", loaded_points), kLoadedPoint, thick * 2});
    legend.push_back({fmt::format("added points ({})", scene.points.size() - loaded_points),
                      kAddedPoint, thick * 2});
  }
  if (options.frusta) {
    size_t loaded_keyframes = 0;
    for (const SceneKeyFrame& kf : scene.keyframes) loaded_keyframes += kf.loaded ? 1 : 0;
    if (loaded_keyframes > 0) {
      legend.push_back(
          {fmt::format("loaded keyframes ({})", loaded_keyframes), kLoadedFrustum, thin});
      legend.push_back(
          {fmt::format("added keyframes ({})", scene.keyframes.size() - loaded_keyframes), kFrustum,
           thin});
    } else {
      legend.push_back({fmt::format("keyframes ({})", scene.keyframes.size()), kFrustum, thin});
    }
  }
  if (options.trajectory) legend.push_back({"keyframe trajectory", kTrajectory, thick});
  if (options.spanning_tree) legend.push_back({"spanning tree", kSpanningTree, thin});
  if (options.covisibility) {
    legend.push_back(
        {fmt::format("covisibility >= {}", options.covisibility_min_weight), kCovisibility, thin});
  }
  if (loop_edges > 0)
    legend.push_back({fmt::format("loop edges ({})", loop_edges), kLoopEdge, thick});
  if (!grid_note.empty()) legend.push_back({grid_note, kGrid, thin});
  DrawLegend(image, layout, legend, occupied);
  for (const LegendEntry& entry : legend) picture.labels.push_back(entry.label);

  const double below = layout.footer_y;
  if (!split_by_age && !values.empty()) {
    // Observations are coloured on a log scale; the bar names counts.
    const bool log_scale = options.colouring == PointColouring::kObservations;
    DrawColourBar(image, layout, {area.x + 4.0 * layout.text_height, below}, colormap,
                  log_scale ? std::exp2(value_lo) : value_lo,
                  log_scale ? std::round(std::exp2(value_hi)) : value_hi, bar_caption);
    picture.labels.push_back(bar_caption);
  }
  if (kind != MapViewKind::kPerspective) {
    // Scale bar: a round length about a fifth of the area's width, bottom right.
    const double length = NiceStep(area.width / 5.0 / projection.pixels_per_metre);
    const double pixels = length * projection.pixels_per_metre;
    const double y = below;
    const double x1 = area.br().x, x0 = x1 - pixels;
    cv::line(image, SubPixel({x0, y}), SubPixel({x1, y}), kText, thick, cv::LINE_AA, kShift);
    for (double x : {x0, x1}) {
      cv::line(image, SubPixel({x, y - layout.tick}), SubPixel({x, y + layout.tick}), kText, thin,
               cv::LINE_AA, kShift);
    }
    const std::string text = length < 1 ? TickLabel(length * 100, length * 100) + " cm"
                                        : TickLabel(length, length) + " m";
    PutText(image, text, {x0 - layout.text_height * 0.6, y}, layout.font, 1, 1, 0.5);
    picture.labels.push_back("scale " + text);
  }
  return picture;
}

}  // namespace rrslam
