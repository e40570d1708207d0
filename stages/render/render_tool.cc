#include "stages/render/render_tool.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <iostream>
#include <set>

#include "common/atomic_file.h"
#include "common/cli.h"
#include "common/dataset.h"
#include "common/errors.h"
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/settings.h"
#include "common/trajectory.h"
#include "common/worker_pool.h"
#include "stages/mapstore/map_file.h"
#include "stages/render/export_frame.h"
#include "stages/render/image_file.h"
#include "stages/render/map_scene.h"

namespace rrslam {
namespace {

MapViewKind ParseView(const std::string& name) {
  if (name == "top") return MapViewKind::kTop;
  if (name == "side") return MapViewKind::kSide;
  if (name == "front") return MapViewKind::kFront;
  if (name == "perspective") return MapViewKind::kPerspective;
  throw UsageError("--view " + name + ": must be top, side, front or perspective");
}

PointColouring ParseColouring(const std::string& name) {
  if (name == "height") return PointColouring::kHeight;
  if (name == "observations") return PointColouring::kObservations;
  if (name == "age") return PointColouring::kAge;
  throw UsageError("--color " + name + ": must be height, observations or age");
}

ImageMetadata Metadata(const std::string& description, const nlohmann::ordered_json& options) {
  ImageMetadata metadata;
  metadata.software = Producer("render");
  metadata.description = description;
  metadata.attributes.emplace_back("rrslam:options", DumpJson(options));
  return metadata;
}

std::string Describe(const std::vector<std::filesystem::path>& paths) {
  std::string text;
  for (const auto& path : paths) text += (text.empty() ? "" : " ") + path.string();
  return text;
}

}  // namespace

void PrepareOutputFolder(const std::filesystem::path& out) {
  std::error_code ec;
  if (std::filesystem::is_directory(out, ec)) return;
  if (std::filesystem::exists(out, ec)) {
    throw CantCreateError(out.string() + ": exists and is not a folder");
  }
  const std::filesystem::path parent =
      out.has_parent_path() ? out.parent_path() : std::filesystem::path(".");
  if (!std::filesystem::is_directory(parent, ec)) {
    throw CantCreateError(out.string() + ": cannot create: " + parent.string() +
                          " is not a folder");
  }
  if (!std::filesystem::create_directory(out, ec) && ec) {
    throw CantCreateError(out.string() + ": cannot create: " + ec.message());
  }
}

// ---------------------------------------------------------------------------
// map

bool RenderMapOptions::Check(std::string* why) const {
  if (map.empty()) {
    *why = "--map is required";
    return false;
  }
  if (out.empty()) {
    *why = "--out is required";
    return false;
  }
  if (views.empty()) {
    *why = "--view: at least one view";
    return false;
  }
  if (!CheckOutputNotInput({"--out", out}, {{"--map", map}, {"--viewpoint", viewpoint}}, why)) {
    return false;
  }
  try {
    for (const std::string& view : views) ParseView(view);
    ParseColouring(colour);
  } catch (const UsageError& e) {
    *why = e.what();
    return false;
  }
  return CheckFrameName(frame, why) && picture.Check(why);
}

std::vector<std::filesystem::path> RunRenderMap(const RenderMapOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  MapPictureOptions picture = options.picture;
  picture.colouring = ParseColouring(options.colour);
  if (!options.viewpoint.empty()) picture.viewpoint = ReadViewpoint(options.viewpoint);
  const FramedMap framed = LoadMapInFrame(options.map, options.frame);
  const MapScene& scene = framed.scene;
  if (framed.floor()) picture.up = "z";
  PrepareOutputFolder(options.out);
  // Views are drawn and encoded on two threads (each file is its own).
  std::vector<std::filesystem::path> written(options.views.size());
  WorkerPool pool(2);
  pool.ParallelFor(options.views.size(), [&](size_t i) {
    const std::string& name = options.views[i];
    const MapPicture rendered = RenderMapPicture(scene, ParseView(name), picture);
    const std::filesystem::path path = options.out / ("map_" + name + ".png");
    nlohmann::ordered_json json = {
        {"map", options.map.string()}, {"view", name}, {"frame", framed.comment}};
    json["picture"] = picture.ToJson();
    WritePicture(path, rendered.image, Metadata(rendered.title, json));
    written[i] = path;
  });
  return written;
}

// ---------------------------------------------------------------------------
// trajectory

bool RenderTrajectoryOptions::Check(std::string* why) const {
  if (estimates.empty()) {
    *why = "--est is required (one or more TUM trajectories)";
    return false;
  }
  if (out.empty()) {
    *why = "--out is required";
    return false;
  }
  std::vector<NamedPath> inputs = {{"--gt", ground_truth}};
  for (const auto& est : estimates) inputs.push_back({"--est", est});
  if (!CheckOutputNotInput({"--out", out}, inputs, why)) return false;
  return picture.Check(why);
}

std::vector<std::filesystem::path> RunRenderTrajectory(const RenderTrajectoryOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  std::vector<NamedTrajectory> estimates;
  for (const auto& path : options.estimates) {
    estimates.push_back({path.filename().string(), ReadTumTrajectory(path)});
    // Two files of one name (run1/CameraTrajectory.txt, run2/...): name by folder too.
    for (size_t i = 0; i + 1 < estimates.size(); ++i) {
      if (estimates[i].name == estimates.back().name) {
        for (size_t j = 0; j < estimates.size(); ++j) {
          const auto& p = options.estimates[j];
          estimates[j].name = (p.parent_path().filename() / p.filename()).string();
        }
        break;
      }
    }
  }
  std::optional<NamedTrajectory> gt;
  if (!options.ground_truth.empty()) {
    gt = NamedTrajectory{options.ground_truth.string(), ReadTumTrajectory(options.ground_truth)};
  }
  const TrajectoryPictures pictures = RenderTrajectoryPictures(estimates, gt, options.picture);
  PrepareOutputFolder(options.out);
  nlohmann::ordered_json json = {{"ground_truth", options.ground_truth.string()}};
  for (const auto& path : options.estimates) json["estimates"].push_back(path.string());
  json["picture"] = options.picture.ToJson();
  std::vector<std::filesystem::path> written;
  const auto write = [&](const std::string& name, const cv::Mat& image, const std::string& what) {
    const std::filesystem::path path = options.out / name;
    WritePicture(path, image, Metadata(what, json));
    written.push_back(path);
  };
  write("trajectory_top.png", pictures.top, "trajectories, top view");
  write("trajectory_side.png", pictures.side, "trajectories, side view");
  write("trajectory_front.png", pictures.front, "trajectories, front view");
  if (!pictures.error.empty()) {
    write("trajectory_error.png", pictures.error, "ATE error over time");
    for (size_t i = 0; i < estimates.size(); ++i) {
      std::cout << fmt::format("{}: ATE RMSE {:.4f} m over {} pairs\n", estimates[i].name,
                               pictures.ate[i].error.rmse, pictures.ate[i].pairs.size());
    }
  }
  return written;
}

// ---------------------------------------------------------------------------
// ply

bool RenderPlyOptions::Check(std::string* why) const {
  if (map.empty()) {
    *why = "--map is required";
    return false;
  }
  if (out.empty()) {
    *why = "--out is required";
    return false;
  }
  if (!associations.empty() && sequence.empty()) {
    *why = "--associations needs --sequence";
    return false;
  }
  return CheckOutputNotInput(
             {"--out", out},
             {{"--map", map}, {"--sequence", sequence}, {"--associations", associations}}, why) &&
         CheckFrameName(frame, why);
}

PlyCloud MapPointCloud(const MapScene& scene, const std::filesystem::path& sequence_dir,
                       const std::filesystem::path& associations) {
  PlyCloud cloud;
  const size_t n = scene.points.size();
  cloud.positions.reserve(n);
  cloud.normals.reserve(n);
  cloud.observations.reserve(n);
  for (const ScenePoint& p : scene.points) {
    cloud.positions.push_back(p.position.cast<float>());
    // The map stores the mean viewing direction (camera -> point); PLY
    // viewers shade with normals facing the viewer.
    const Eigen::Vector3d n =
        p.normal.norm() > 0 ? (-p.normal.normalized()).eval() : Eigen::Vector3d::Zero();
    cloud.normals.push_back(n.cast<float>());
    cloud.observations.push_back(p.observations);
  }
  cloud.colors.assign(n, {128, 128, 128});
  if (sequence_dir.empty()) return cloud;

  SequenceOptions sequence_options;
  sequence_options.associations = associations;
  sequence_options.max_image_size = {scene.camera.width, scene.camera.height,
                                     "the camera of " + scene.source};
  const RgbdSequence sequence = RgbdSequence::Open(sequence_dir, sequence_options);
  const std::vector<size_t> frames = KeyFrameFrames(scene, sequence);
  // Each keyframe's image is read once; a point's colour is the mean over
  // its observations.
  std::vector<std::vector<std::pair<size_t, cv::Point2f>>> by_keyframe(scene.keyframes.size());
  for (size_t i = 0; i < n; ++i) {
    for (const SceneObservation& o : scene.points[i].seen_at) {
      if (const auto k = scene.FindKeyFrame(o.keyframe)) {
        by_keyframe[*k].push_back({i, cv::Point2f(o.pixel_x, o.pixel_y)});
      }
    }
  }
  std::vector<Eigen::Vector3d> sums(n, Eigen::Vector3d::Zero());
  std::vector<int> counts(n, 0);
  for (size_t k = 0; k < by_keyframe.size(); ++k) {
    if (by_keyframe[k].empty()) continue;
    const cv::Mat image = sequence.LoadColor(frames[k]);
    for (const auto& [i, pixel] : by_keyframe[k]) {
      const int x = static_cast<int>(std::lround(pixel.x));
      const int y = static_cast<int>(std::lround(pixel.y));
      if (x < 0 || y < 0 || x >= image.cols || y >= image.rows) continue;
      const cv::Vec3b bgr = image.at<cv::Vec3b>(y, x);
      sums[i] += Eigen::Vector3d(bgr[2], bgr[1], bgr[0]);
      ++counts[i];
    }
  }
  for (size_t i = 0; i < n; ++i) {
    if (counts[i] == 0) continue;
    const Eigen::Vector3d mean = sums[i] / counts[i];
    cloud.colors[i] = {static_cast<uint8_t>(std::lround(mean[0])),
                       static_cast<uint8_t>(std::lround(mean[1])),
                       static_cast<uint8_t>(std::lround(mean[2]))};
  }
  return cloud;
}

std::filesystem::path RunRenderPly(const RenderPlyOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const FramedMap framed =
      LoadMapInFrame(options.map, options.frame, options.sequence, options.associations);
  PlyCloud cloud = MapPointCloud(framed.scene, options.sequence, options.associations);
  cloud.comments.push_back("producer " + Producer("render"));
  cloud.comments.push_back("map " + options.map.string());
  cloud.comments.push_back(options.sequence.empty()
                               ? std::string("colour grey (no --sequence)")
                               : "colour from keyframe images of " + options.sequence.string());
  cloud.comments.push_back(framed.comment);
  WritePly(options.out, cloud, options.binary ? PlyFormat::kBinaryLittleEndian : PlyFormat::kAscii);
  return options.out;
}

bool RenderColmapOptions::Check(std::string* why) const {
  if (map.empty() || sequence.empty() || out.empty()) {
    *why = "--map, --sequence and --out are required";
    return false;
  }
  return CheckOutputNotInput(
             {"--out", out},
             {{"--map", map}, {"--sequence", sequence}, {"--associations", associations}}, why) &&
         CheckFrameName(frame, why);
}

namespace {

// The keyframes' colour images of `sequence`, in the map's keyframe order.
std::vector<std::filesystem::path> KeyFrameImageFiles(const MapScene& scene,
                                                      const RenderColmapOptions& o) {
  SequenceOptions sequence_options;
  sequence_options.associations = o.associations;
  const RgbdSequence sequence = RgbdSequence::Open(o.sequence, sequence_options);
  std::vector<std::filesystem::path> images;
  for (size_t frame : KeyFrameFrames(scene, sequence)) {
    images.push_back(sequence.frame(frame).rgb_path);
  }
  return images;
}

// Image names under DIR/images: the file names, numbered when two collide.
std::vector<std::string> ImageNames(const std::vector<std::filesystem::path>& images) {
  std::vector<std::string> names;
  std::set<std::string> taken;
  for (size_t k = 0; k < images.size(); ++k) {
    std::string name = images[k].filename().string();
    if (!taken.insert(name).second) name = fmt::format("{:06d}-{}", k, name);
    taken.insert(name);
    names.push_back(name);
  }
  return names;
}

}  // namespace

std::vector<std::filesystem::path> RunRenderColmap(const RenderColmapOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw UsageError(why);
  const FramedMap framed = LoadMapInFrame(o.map, o.frame, o.sequence, o.associations);
  const std::vector<std::filesystem::path> images = KeyFrameImageFiles(framed.scene, o);
  const std::vector<std::string> names = ImageNames(images);
  const PlyCloud cloud = MapPointCloud(framed.scene, o.sequence, o.associations);
  const ColmapModel model = ColmapModelOf(framed.data, names, cloud.colors);
  PrepareOutputFolder(o.out);
  const std::filesystem::path image_dir = o.out / "images", model_dir = o.out / "sparse" / "0";
  for (const std::filesystem::path& dir : {image_dir, model_dir}) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw CantCreateError(dir.string() + ": cannot create: " + ec.message());
  }
  std::vector<std::filesystem::path> written;
  for (size_t k = 0; k < images.size(); ++k) {
    written.push_back(image_dir / names[k]);
    WriteFileAtomically(written.back(), ReadFileToString(images[k]));
  }
  WriteColmapModel(model, model_dir, o.binary);
  written.push_back(model_dir);
  written.push_back(o.out / "frame.txt");
  WriteFileAtomically(written.back(),
                      "# rrslam-render colmap of " + o.map.string() + "\n" + framed.comment + "\n");
  spdlog::info("render: COLMAP model of {} images, {} points in {}", model.images.size(),
               model.points.size(), model_dir.string());
  return written;
}

// ---------------------------------------------------------------------------
// Binding

void BindRenderCommands(CLI::App& app, RenderCommands* c) {
  app.require_subcommand(1);

  CLI::App* map = app.add_subcommand("map", "PNG pictures of a saved map (DIR/map_<view>.png)");
  map->add_option("--map", c->map.map, "Map file (rrslam.map)")->required();
  map->add_option("--out", c->map.out, "Output folder (created when missing)")->required();
  map->add_option("--view", c->map.views,
                  "top, side, front, perspective; repeatable (default: all four)")
      ->expected(1, 4)
      ->capture_default_str();
  map->add_option("--viewpoint", c->map.viewpoint,
                  "Settings YAML with Viewer.ViewpointX/Y/Z/F (ORB-SLAM2's viewer camera) for "
                  "the perspective view; default: ORB-SLAM2's direction, framing the map");
  map->add_option("--color", c->map.colour,
                  "Point colour: height, observations, or age (loaded vs. added after restore "
                  "mapping; else creation order)")
      ->capture_default_str();
  AddFrameOption(map, &c->map.frame);
  map->add_option("--up", c->map.picture.up, "World axis pointing up (first camera level: -y)")
      ->capture_default_str();
  map->add_option("--width", c->map.picture.width_px, "Image width, pixels [320, 8000]")
      ->capture_default_str();
  map->add_option("--height", c->map.picture.height_px, "Image height, pixels [240, 8000]")
      ->capture_default_str();
  map->add_flag("--covisibility", c->map.picture.covisibility,
                "Draw covisibility edges (weight >= --covisibility-min)");
  map->add_option("--covisibility-min", c->map.picture.covisibility_min_weight,
                  "Smallest covisibility weight drawn (shared points)")
      ->capture_default_str();
  map->add_flag("!--no-spanning-tree", c->map.picture.spanning_tree,
                "Do not draw the spanning tree");
  map->add_flag("!--no-frusta", c->map.picture.frusta, "Do not draw keyframe frusta");
  map->add_flag("!--no-trajectory", c->map.picture.trajectory,
                "Do not draw the keyframe trajectory");
  map->add_option("--frustum-size", c->map.picture.frustum_size,
                  "Frustum depth, metres (0 = 2% of the map's extent)")
      ->capture_default_str();
  map->callback([c] { c->chosen = "map"; });

  CLI::App* trajectory = app.add_subcommand(
      "trajectory",
      "Top, side and front views of TUM trajectories against a ground truth, error over time");
  trajectory
      ->add_option("--est", c->trajectory.estimates,
                   "TUM trajectory (CameraTrajectory.txt or KeyFrameTrajectory.txt); "
                   "repeatable")
      ->required();
  trajectory->add_option("--gt", c->trajectory.ground_truth,
                         "TUM ground truth; estimates are aligned to it (rigid, as ATE)");
  trajectory->add_option("--out", c->trajectory.out, "Output folder (created when missing)")
      ->required();
  trajectory->add_option("--title", c->trajectory.picture.title, "Title prefix (e.g. sequence)");
  trajectory
      ->add_option("--max-difference", c->trajectory.picture.max_difference,
                   "Seconds: largest stamp difference of an associated pair")
      ->capture_default_str();
  trajectory->add_option("--width", c->trajectory.picture.width_px, "Image width, pixels")
      ->capture_default_str();
  trajectory->add_option("--height", c->trajectory.picture.height_px, "Image height, pixels")
      ->capture_default_str();
  trajectory->callback([c] { c->chosen = "trajectory"; });

  CLI::App* ply = app.add_subcommand(
      "ply", "Map points as PLY (position, normal, colour, observations) for MeshLab/CloudCompare");
  ply->add_option("--map", c->ply.map, "Map file (rrslam.map)")->required();
  ply->add_option("--out", c->ply.out, "PLY file")->required();
  ply->add_option("--sequence", c->ply.sequence,
                  "Sequence folder the map was built from: colours from its keyframe images "
                  "(default: grey)");
  ply->add_option("--associations", c->ply.associations,
                  "Associations file of the sequence (as rrslam-track)");
  ply->add_flag("--binary,!--ascii", c->ply.binary,
                "PLY as binary little-endian (default: 3x smaller, exact floats, read as fast as "
                "any viewer can) or --ascii");
  AddFrameOption(ply, &c->ply.frame);
  ply->callback([c] { c->chosen = "ply"; });

  CLI::App* html = app.add_subcommand(
      "html", "One self-contained HTML file with a 3D view of the map you can orbit (offline)");
  BindHtmlOptions(html, &c->html);
  html->callback([c] { c->chosen = "html"; });

  CLI::App* dense = app.add_subcommand(
      "dense", "Fuse the keyframes' depth and colour into a TSDF volume: coloured PLY and PNG");
  BindDenseOptions(dense, &c->dense);
  dense->callback([c] { c->chosen = "dense"; });

  CLI::App* colmap = app.add_subcommand(
      "colmap", "The map as a COLMAP sparse model (DIR/sparse/0) with its images (DIR/images)");
  colmap->add_option("--map", c->colmap.map, "Map file (rrslam.map)")->required();
  colmap
      ->add_option("--sequence", c->colmap.sequence,
                   "Sequence folder the map was built from (keyframe images, colours)")
      ->required();
  colmap->add_option("--associations", c->colmap.associations,
                     "Associations file of the sequence (as rrslam-track)");
  colmap->add_option("--out", c->colmap.out, "Output folder (created when missing)")->required();
  colmap->add_flag("--binary", c->colmap.binary,
                   "cameras.bin, images.bin, points3D.bin instead of the .txt files");
  AddFrameOption(colmap, &c->colmap.frame);
  colmap->callback([c] { c->chosen = "colmap"; });

  CLI::App* octomap = app.add_subcommand(
      "octomap", "Keyframe depth integrated into an OctoMap (.bt: free, occupied, unknown)");
  BindOctomapOptions(octomap, &c->octomap);
  octomap->callback([c] { c->chosen = "octomap"; });

  CLI::App* grid = app.add_subcommand(
      "grid",
      "2D occupancy grid for navigation in the floor frame (map_server YAML + PGM, and a PNG "
      "picture); exit 75 when the map has no floor");
  BindGridOptions(grid, &c->grid);
  grid->callback([c] { c->chosen = "grid"; });
}

void RunRenderCommand(const RenderCommands& c) {
  if (c.chosen == "map") {
    const auto written = RunRenderMap(c.map);
    spdlog::info("render: wrote {}", Describe(written));
  } else if (c.chosen == "trajectory") {
    const auto written = RunRenderTrajectory(c.trajectory);
    spdlog::info("render: wrote {}", Describe(written));
  } else if (c.chosen == "ply") {
    spdlog::info("render: wrote {}", RunRenderPly(c.ply).string());
  } else if (c.chosen == "html") {
    RunHtml(c.html);
  } else if (c.chosen == "dense") {
    RunDense(c.dense);
  } else if (c.chosen == "colmap") {
    RunRenderColmap(c.colmap);
  } else if (c.chosen == "octomap") {
    RunOctomap(c.octomap);
  } else if (c.chosen == "grid") {
    RunGrid(c.grid);
  } else {
    throw UsageError(
        "a command is required: map, trajectory, ply, html, dense, colmap, octomap or grid");
  }
}

}  // namespace rrslam
