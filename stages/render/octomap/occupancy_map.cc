#include "stages/render/octomap/occupancy_map.h"

#include <fmt/format.h>
#include <octomap/OcTree.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <iostream>
#include <sstream>
#include <utility>

#include "common/atomic_file.h"
#include "common/cli.h"
#include "common/clock.h"
#include "common/errors.h"
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/text.h"

namespace rrslam {
namespace {

bool Fail(std::string* why, const std::string& text) {
  *why = text;
  return false;
}

// The rays of one depth image: endpoints in the frame, every `stride`-th
// pixel with a measurement.
octomap::Pointcloud DepthRays(const cv::Mat& depth, const KeyFrameCamera& camera,
                              const Rigid3d& T_frame_cam, int stride) {
  const Eigen::Matrix3d R = T_frame_cam.RotationMatrix();
  const Eigen::Vector3d& t = T_frame_cam.translation;
  octomap::Pointcloud cloud;
  cloud.reserve(static_cast<size_t>(depth.rows / stride + 1) * (depth.cols / stride + 1));
  for (int v = 0; v < depth.rows; v += stride) {
    const float* row = depth.ptr<float>(v);
    for (int u = 0; u < depth.cols; u += stride) {
      const double z = row[u];
      if (!(z > 0) || !std::isfinite(z)) continue;
      const Eigen::Vector3d point_cam((u - camera.cx) * z / camera.fx,
                                      (v - camera.cy) * z / camera.fy, z);
      const Eigen::Vector3d p = R * point_cam + t;
      cloud.push_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                      static_cast<float>(p.z()));
    }
  }
  return cloud;
}

void CountLeaves(const octomap::OcTree& tree, IntegrationStats* stats) {
  stats->nodes = tree.size();
  stats->leaves = 0;
  stats->occupied_leaves = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    ++stats->leaves;
    if (tree.isNodeOccupied(*it)) ++stats->occupied_leaves;
  }
  stats->memory_bytes = tree.memoryUsage();
  tree.getMetricMin(stats->min.x(), stats->min.y(), stats->min.z());
  tree.getMetricMax(stats->max.x(), stats->max.y(), stats->max.z());
}

}  // namespace

bool DepthIntegrationOptions::Check(std::string* why) const {
  if (!(resolution >= 0.005 && resolution <= 1)) {
    return Fail(why, "--resolution = " + Format("%g", resolution) + "; must be in [0.005, 1] m");
  }
  if (!(max_range > 0) || !std::isfinite(max_range)) {
    return Fail(why, "--max-range = " + Format("%g", max_range) + "; must be > 0 metres");
  }
  if (pixel_stride < 1 || pixel_stride > 16) {
    return Fail(why, "--pixel-stride = " + std::to_string(pixel_stride) + "; must be in [1, 16]");
  }
  return true;
}

nlohmann::ordered_json DepthIntegrationOptions::ToJson() const {
  return {{"resolution", resolution}, {"max_range", max_range}, {"pixel_stride", pixel_stride}};
}

void BindDepthIntegrationOptions(CLI::App* command, DepthIntegrationOptions* o) {
  command->add_option("--resolution", o->resolution, "Voxel edge, metres")->capture_default_str();
  command
      ->add_option("--max-range", o->max_range,
                   "Depth farther than this from the camera, metres, only clears free space")
      ->capture_default_str();
  command
      ->add_option("--pixel-stride", o->pixel_stride,
                   "Cast every n-th depth pixel of each row and column")
      ->capture_default_str();
}

nlohmann::ordered_json IntegrationStats::ToJson() const {
  return {{"keyframes", keyframes},
          {"rays", rays},
          {"nodes", nodes},
          {"leaves", leaves},
          {"occupied_leaves", occupied_leaves},
          {"memory_bytes", memory_bytes},
          {"integrate_seconds", integrate_seconds},
          {"min", {min.x(), min.y(), min.z()}},
          {"max", {max.x(), max.y(), max.z()}}};
}

std::unique_ptr<octomap::OcTree> IntegrateDepth(const DepthIntegrationOptions& options,
                                                const KeyFrameCamera& camera,
                                                const std::vector<Rigid3d>& T_frame_cams,
                                                const DepthLoader& load, IntegrationStats* stats) {
  const auto start = SteadyClock::now();
  auto tree = std::make_unique<octomap::OcTree>(options.resolution);
  *stats = IntegrationStats{};
  for (size_t i = 0; i < T_frame_cams.size(); ++i) {
    const cv::Mat depth = load(i);
    if (depth.type() != CV_32FC1 || depth.cols != camera.width || depth.rows != camera.height) {
      throw DataError(fmt::format("view {}: depth is {}x{} (type {}); the camera is {}x{} CV_32FC1",
                                  i, depth.cols, depth.rows, depth.type(), camera.width,
                                  camera.height));
    }
    const octomap::Pointcloud rays =
        DepthRays(depth, camera, T_frame_cams[i], options.pixel_stride);
    const Eigen::Vector3d& c = T_frame_cams[i].translation;
    // Discretized (one ray per end voxel) and lazy: inner nodes once, at the end.
    tree->insertPointCloud(rays, octomap::point3d(c.x(), c.y(), c.z()), options.max_range,
                           /*lazy_eval=*/true, /*discretize=*/true);
    stats->rays += rays.size();
    ++stats->keyframes;
  }
  if (stats->rays == 0) {
    throw DataError(fmt::format("none of the {} views has depth", T_frame_cams.size()));
  }
  tree->updateInnerOccupancy();
  // What the .bt holds: each voxel free or occupied (unknown: no node), merged.
  tree->toMaxLikelihood();
  tree->prune();
  stats->integrate_seconds = MillisecondsSince(start) / 1000.0;
  CountLeaves(*tree, stats);
  return tree;
}

bool MapDepthInput::Check(const std::vector<NamedPath>& outputs, std::string* why) const {
  if (map.empty() || sequence.empty()) return Fail(why, "--map and --sequence are required");
  return CheckOutputs(
      outputs, {{"--map", map}, {"--sequence", sequence}, {"--associations", associations}}, why);
}

void MapDepthInput::AddToJson(nlohmann::ordered_json* json) const {
  (*json)["map"] = map.string();
  (*json)["sequence"] = sequence.string();
  (*json)["associations"] = associations.string();
}

void BindMapDepthInput(CLI::App* command, MapDepthInput* input) {
  command->add_option("--map", input->map, "Map file (rrslam.map)")->required();
  command
      ->add_option("--sequence", input->sequence,
                   "RGB-D sequence folder the map was built from (keyframe depth by timestamp)")
      ->required();
  command->add_option("--associations", input->associations,
                      "Associations file of the sequence (as rrslam-track)");
}

MapOctree IntegrateMap(FramedMap map, const MapDepthInput& input,
                       const DepthIntegrationOptions& options) {
  MapOctree result;
  result.map = std::move(map);
  const MapScene& scene = result.map.scene;
  CheckFusableMap(scene);
  const KeyFrameImages images(scene, input.sequence, input.associations);
  std::vector<Rigid3d> poses;
  for (const SceneKeyFrame& keyframe : scene.keyframes) poses.push_back(keyframe.T_world_cam);
  spdlog::info("render: integrating the depth of {} keyframes of {} at {} m{}", poses.size(),
               input.map.string(), options.resolution, images.undistorts() ? " (undistorted)" : "");
  result.tree = IntegrateDepth(
      options, images.camera(), poses,
      [&images](size_t index) { return images.Load(index, /*with_color=*/false).depth; },
      &result.stats);
  return result;
}

void WriteOctree(const octomap::OcTree& tree, const std::vector<std::string>& comments,
                 AtomicOutput* output) {
  std::ostringstream bytes;
  if (!tree.writeBinaryConst(bytes)) throw AlgorithmError("OctoMap could not serialize the tree");
  std::string content = bytes.str();
  // OctoMap's header invites comments after its first line.
  std::string lines;
  for (const std::string& comment : comments) lines += "# " + comment + "\n";
  content.insert(content.find('\n') + 1, lines);
  CommitContent(output, content);
}

bool OctomapOptions::Check(std::string* why) const {
  if (out.empty()) return Fail(why, "--out is required");
  if (AsciiLowercase(out.extension().string()) != ".bt") {
    return Fail(why, "--out " + out.string() + " must be a .bt file (OctoMap's binary format)");
  }
  return input.Check({{"--out", out}}, why) && CheckFrameName(frame, why) && integration.Check(why);
}

nlohmann::ordered_json OctomapOptions::ToJson() const {
  nlohmann::ordered_json j;
  input.AddToJson(&j);
  j["out"] = out.string();
  j["frame"] = frame;
  j["integration"] = integration.ToJson();
  return j;
}

void BindOctomapOptions(CLI::App* command, OctomapOptions* o) {
  BindMapDepthInput(command, &o->input);
  command->add_option("--out", o->out, "OctoMap file to write (.bt)")->required();
  AddFrameOption(command, &o->frame);
  BindDepthIntegrationOptions(command, &o->integration);
}

IntegrationStats RunOctomap(const OctomapOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  AtomicOutput output(options.out);  // Its folder checked before the integration.
  const MapDepthInput& in = options.input;
  MapOctree octree = IntegrateMap(
      LoadMapInFrame(in.map, options.frame, in.sequence, in.associations), in, options.integration);
  WriteOctree(
      *octree.tree,
      {"producer " + Producer("render"), "rrslam-render octomap of " + options.input.map.string(),
       octree.map.comment, "options " + DumpJson(options.ToJson())},
      &output);
  const IntegrationStats& s = octree.stats;
  std::cout << fmt::format(
      "octomap: {} keyframes, {} rays; tree of {} nodes ({} leaves, {} occupied) at {} m, "
      "{:.0f} MB, {:.1f} s; {}\nwrote {}\n",
      s.keyframes, s.rays, s.nodes, s.leaves, s.occupied_leaves, options.integration.resolution,
      s.memory_bytes / 1e6, s.integrate_seconds, octree.map.comment, options.out.string());
  return s;
}

}  // namespace rrslam
