#include "stages/synth/synth.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "common/atomic_file.h"
#include "common/cli.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "common/json_text.h"
#include "common/progress.h"
#include "common/worker_pool.h"
#include "stages/synth/building.h"
#include "stages/synth/renderer.h"
#include "stages/synth/scene.h"
#include "stages/synth/sensor.h"

namespace rrslam {
namespace fs = std::filesystem;
namespace {

constexpr double kDepthMapFactor = 5000.0;
// Disparity error (pixels) of a depth read at a keypoint's nearest pixel,
// beyond the sensor's noise. Chosen from the sweep in docs/track.md ("Depth
// weighting"), where 0.06 to 0.3 px all beat ORB-SLAM2's weighting.
constexpr double kDepthSamplingSigma = 0.1;

nlohmann::ordered_json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// A box of the scene summary: where it is and its axis-aligned bounds.
nlohmann::ordered_json BoxJson(const synth::Box& box) {
  const Eigen::AlignedBox3d bounds = synth::BoxBounds(box);
  nlohmann::ordered_json j;
  j["centre"] = Vec(box.centre_world);
  j["size"] = Vec(box.size);
  j["yaw_deg"] = box.yaw * 180.0 / M_PI;
  j["bounds_min"] = Vec(bounds.min());
  j["bounds_max"] = Vec(bounds.max());
  return j;
}

// The scene_change section of synth.json (SceneChangeInfo).
nlohmann::ordered_json SceneChangeJson(const synth::SceneChangeInfo& info) {
  nlohmann::ordered_json j;
  j["name"] = synth::SceneChangeName(info.change);
  j["moved"] = nlohmann::ordered_json::array();
  for (const synth::SceneChangeInfo::Move& m : info.moved) {
    nlohmann::ordered_json move;
    move["box"] = m.from.name;
    move["index"] = m.index;
    move["from"] = BoxJson(m.from);
    move["to"] = BoxJson(m.to);
    move["displacement_m"] = (m.to.centre_world - m.from.centre_world).norm();
    j["moved"].push_back(move);
  }
  j["added"] = nlohmann::ordered_json::array();
  for (const synth::SceneChangeInfo::Addition& a : info.added) {
    nlohmann::ordered_json add;
    add["box"] = a.box.name;
    add["index"] = a.index;
    add["material"] = synth::MaterialName(a.box.materials[0]);
    add.update(BoxJson(a.box));
    j["added"].push_back(add);
  }
  return j;
}

std::string Num(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.9g", v);
  return buffer;
}

// Fails Check with a message naming the option, its value and the constraint.
bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

int ResolveThreads(int threads) {
  if (threads > 0) return threads;
  return std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace

bool SynthOptions::Check(std::string* why) const {
  if (frames < 1 || frames > 100000) {
    return Fail(why, "frames = " + std::to_string(frames) + "; must be in [1, 100000]");
  }
  if (!(fps > 0 && fps <= 1000)) return Fail(why, "fps = " + Num(fps) + "; must be in (0, 1000]");
  if (width < 16 || width > 8192) {
    return Fail(why, "width = " + std::to_string(width) + "; must be in [16, 8192]");
  }
  if (height < 16 || height > 8192) {
    return Fail(why, "height = " + std::to_string(height) + "; must be in [16, 8192]");
  }
  if (fx != 0 && !(fx >= 1 && fx <= 100000)) {
    return Fail(why, "fx = " + Num(fx) + "; must be 0 (default) or in [1, 100000]");
  }
  if (fy != 0 && !(fy >= 1 && fy <= 100000)) {
    return Fail(why, "fy = " + Num(fy) + "; must be 0 (default) or in [1, 100000]");
  }
  if (!(cx >= 0 && cx <= width - 1)) {
    return Fail(why, "cx = " + Num(cx) + "; must be 0 (default) or in (0, width - 1]");
  }
  if (!(cy >= 0 && cy <= height - 1)) {
    return Fail(why, "cy = " + Num(cy) + "; must be 0 (default) or in (0, height - 1]");
  }
  if (!(depth_noise >= 0 && depth_noise <= 0.05)) {
    return Fail(why, "depth_noise = " + Num(depth_noise) + "; must be in [0, 0.05]");
  }
  if (!(depth_holes >= 0 && depth_holes <= 0.9)) {
    return Fail(why, "depth_holes = " + Num(depth_holes) + "; must be in [0, 0.9]");
  }
  if (!(depth_scale_error > -0.5 && depth_scale_error < 0.5)) {
    return Fail(why, "depth_scale_error = " + Num(depth_scale_error) + "; must be in (-0.5, 0.5)");
  }
  if (!(depth_scale_wander >= 0 && depth_scale_wander <= 0.2)) {
    return Fail(why, "depth_scale_wander = " + Num(depth_scale_wander) + "; must be in [0, 0.2]");
  }
  if (!(std::abs(depth_scale_error) + depth_scale_wander < 0.5)) {
    return Fail(why, "depth_scale_wander = " + Num(depth_scale_wander) +
                         "; must be below 0.5 - |depth_scale_error|");
  }
  if (!(depth_scale_period >= 0.1 && depth_scale_period <= 3600)) {
    return Fail(why,
                "depth_scale_period = " + Num(depth_scale_period) + "; must be in [0.1, 3600]");
  }
  if (!(brightness_change >= 0 && brightness_change <= 0.9)) {
    return Fail(why, "brightness_change = " + Num(brightness_change) + "; must be in [0, 0.9]");
  }
  if (motion_blur.has_value() && !(*motion_blur >= 0 && *motion_blur <= 64)) {
    return Fail(why, "motion_blur = " + Num(*motion_blur) + "; must be in [0, 64]");
  }
  if (!(texel_size >= 0.0005 && texel_size <= 0.05)) {
    return Fail(why, "texel_size = " + Num(texel_size) + "; must be in [0.0005, 0.05]");
  }
  synth::SceneChange change;
  if (!synth::ParseSceneChange(scene_change, &change)) {
    return Fail(why, "scene_change = " + scene_change + "; must be " + synth::SceneChangeNames());
  }
  if (!CheckSceneAndTrajectory(why)) return false;
  if (threads < 0 || threads > 256) {
    return Fail(why, "threads = " + std::to_string(threads) + "; must be in [0, 256]");
  }
  return true;
}

bool SynthOptions::CheckSceneAndTrajectory(std::string* why) const {
  const bool building = scene == synth::SceneKind::kBuilding;
  const bool tour = trajectory == synth::TrajectoryKind::kTour;
  const std::string trajectory_name = synth::TrajectoryKindName(trajectory);
  if (building && scene_change != "none") {
    return Fail(why, "scene_change = " + scene_change +
                         "; must be none with scene = building (--change " + scene_change +
                         " edits the standard room, not --scene building)");
  }
  if (building && !tour) {
    return Fail(why, "trajectory = " + trajectory_name +
                         "; must be tour with scene = building (--scene building is walked by "
                         "--trajectory tour only)");
  }
  if (!building && tour) {
    return Fail(why,
                "trajectory = tour; must be loop, sweep, rotation, shake or turn with scene = " +
                    synth::SceneKindName(scene) + " (--trajectory tour needs --scene building)");
  }
  return true;
}

double DefaultMotionBlur(synth::TrajectoryKind kind) {
  return kind == synth::TrajectoryKind::kShake ? kShakeMotionBlur : 0.0;
}

double SynthOptions::MotionBlur() const {
  return motion_blur.value_or(DefaultMotionBlur(trajectory));
}

double SynthOptions::DepthScaleError(double t) const {
  if (depth_scale_wander == 0) return depth_scale_error;
  return depth_scale_error + depth_scale_wander * std::sin(2 * M_PI * t / depth_scale_period);
}

PinholeCamera SynthOptions::Camera() const {
  const double rfx = fx != 0 ? fx : 525.0 * width / 640.0;
  const double rfy = fy != 0 ? fy : 525.0 * height / 480.0;
  const double rcx = cx != 0 ? cx : 320.0 * width / 640.0 - 0.5;
  const double rcy = cy != 0 ? cy : 240.0 * height / 480.0 - 0.5;
  return PinholeCamera(rfx, rfy, rcx, rcy, width, height);
}

Settings SynthOptions::MakeSettings() const {
  const PinholeCamera camera = Camera();
  Settings settings;
  settings.fx = camera.fx();
  settings.fy = camera.fy();
  settings.cx = camera.cx();
  settings.cy = camera.cy();
  settings.width = width;
  settings.height = height;
  settings.fps = fps;
  settings.bf = 40.0 * camera.fx() / 525.0;
  settings.rgb_order = true;
  settings.th_depth = 40.0;
  settings.depth_map_factor = kDepthMapFactor;
  // The sensor's depth noise, k z^2 metres, as the quadratic model that
  // tracking weighs depth by. Reading the depth at a keypoint's nearest pixel
  // adds an error of its own (slanted surfaces, depth edges);
  // kDepthSamplingSigma covers it (docs/track.md, "Depth weighting").
  settings.depth_noise = {DepthNoise::Model::kQuadratic, depth_noise, kDepthSamplingSigma};
  return settings;
}

std::string SynthOptions::ToJson() const {
  const PinholeCamera camera = Camera();
  nlohmann::ordered_json j;
  j["scene"] = synth::SceneKindName(scene);
  j["trajectory"] = synth::TrajectoryKindName(trajectory);
  j["frames"] = frames;
  j["fps"] = fps;
  j["width"] = width;
  j["height"] = height;
  j["fx"] = camera.fx();
  j["fy"] = camera.fy();
  j["cx"] = camera.cx();
  j["cy"] = camera.cy();
  j["depth_noise"] = depth_noise;
  j["depth_holes"] = depth_holes;
  j["depth_scale_error"] = depth_scale_error;
  j["depth_scale_wander"] = depth_scale_wander;
  j["depth_scale_period"] = depth_scale_period;
  j["brightness_change"] = brightness_change;
  j["motion_blur"] = MotionBlur();
  j["seed"] = seed;
  j["texel_size"] = texel_size;
  j["scene_change"] = scene_change;
  return DumpJson(j);
}

std::string FormatTimestamp(double seconds) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.6f", seconds);
  return buffer;
}

SyntheticSequence::SyntheticSequence(const SynthOptions& options)
    : options_(options),
      camera_(options.Camera()),
      path_(options.trajectory, options.frames > 0 ? (options.frames - 1) / options.fps : 0.0) {
  std::string why;
  if (!options_.Check(&why)) throw UsageError("invalid option: " + why);
  groundtruth_ = synth::MakeTrajectory(options_.trajectory, options_.frames, options_.fps);
  synth::SceneOptions scene_options;
  scene_options.seed = options_.seed;
  scene_options.texel_size = options_.texel_size;
  scene_options.num_threads = ResolveThreads(options_.threads);
  if (options_.scene == synth::SceneKind::kBuilding) {
    scene_ = std::make_unique<synth::Scene>(synth::Scene::Building(scene_options));
  } else {
    synth::SceneChange change = synth::SceneChange::kNone;
    synth::ParseSceneChange(options_.scene_change, &change);  // Valid: Check passed.
    scene_ = std::make_unique<synth::Scene>(synth::ChangedRoomBoxes(change), scene_options);
  }
  renderer_ = std::make_unique<synth::Renderer>(*scene_, camera_);
}

SyntheticSequence::~SyntheticSequence() = default;

SynthFrame SyntheticSequence::Render(size_t i) const {
  SynthFrame frame;
  frame.timestamp = groundtruth_.at(i).timestamp;
  frame.T_world_cam = groundtruth_[i].T_world_cam;
  const double t = static_cast<double>(i) / options_.fps;
  const synth::RenderedFrame rendered = renderer_->Render(frame.T_world_cam);

  cv::Mat color = rendered.color;
  const double motion_blur = options_.MotionBlur();
  if (motion_blur > 0) {
    // Image motion over one frame interval, averaged over a grid of pixels
    // with depth; the exposure is set so that the image moves `motion_blur`
    // pixels during it (capped at the frame interval).
    const double dt = 1.0 / options_.fps;
    const Rigid3d T_cam_before = path_.T_world_cam(t - 0.5 * dt).Inverse();
    const Rigid3d T_cam_after = path_.T_world_cam(t + 0.5 * dt).Inverse();
    double motion_sum = 0;
    int motion_count = 0;
    for (int gy = 0; gy < 6; ++gy) {
      for (int gx = 0; gx < 8; ++gx) {
        const int u = (2 * gx + 1) * options_.width / 16, v = (2 * gy + 1) * options_.height / 12;
        const double z = rendered.depth.at<float>(v, u);
        if (z <= 0) continue;
        const Eigen::Vector3d point_world =
            frame.T_world_cam * camera_.Unproject(Eigen::Vector2d(u, v), z);
        const Eigen::Vector3d p0 = T_cam_before * point_world, p1 = T_cam_after * point_world;
        if (p0.z() <= 0 || p1.z() <= 0) continue;
        motion_sum += (camera_.Project(p1) - camera_.Project(p0)).norm();
        ++motion_count;
      }
    }
    const double motion = motion_count > 0 ? motion_sum / motion_count : 0.0;  // px per frame.
    const double blur = std::min(motion_blur, motion);
    if (blur >= 0.25) {
      const double exposure = dt * blur / motion;
      const int samples = std::clamp(static_cast<int>(std::ceil(blur)) + 1, 2, 32);
      std::vector<Rigid3d> poses;
      for (int k = 0; k < samples; ++k) {
        poses.push_back(path_.T_world_cam(t + exposure * (k / (samples - 1.0) - 0.5)));
      }
      color = renderer_->RenderAveragedColor(poses);
    }
  }
  const double phase = path_.duration() > 0 ? t / path_.duration() : 0.0;
  frame.color = synth::ToColor8(color, synth::ExposureGain(options_.brightness_change, phase,
                                                           path_.duration(), options_.seed));

  synth::DepthSensorModel model;
  model.scale_error = options_.DepthScaleError(t);
  model.noise_coefficient = options_.depth_noise;
  model.hole_fraction = options_.depth_holes;
  model.depth_map_factor = kDepthMapFactor;
  frame.depth =
      synth::SimulateDepthSensor(rendered.depth, rendered.cos_incidence, model, options_.seed, i);
  return frame;
}

namespace {

// Files inside the output folder are written plainly: the folder as a whole is
// committed atomically (AtomicOutput::Kind::kDirectory), which fsyncs them.
void WriteBytes(const fs::path& path, const char* data, size_t size) {
  std::ofstream stream(path, std::ios::binary | std::ios::trunc);
  stream.write(data, static_cast<std::streamsize>(size));
  stream.flush();
  if (!stream) throw CantCreateError(path.string() + ": cannot write");
}

void WriteText(const fs::path& path, const std::string& text) {
  WriteBytes(path, text.data(), text.size());
}

void WritePngInside(const fs::path& path, const cv::Mat& image) {
  const std::vector<uint8_t> png = EncodePng(image);
  WriteBytes(path, reinterpret_cast<const char*>(png.data()), png.size());
}

}  // namespace

void RunSynth(const SynthOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError("invalid option: " + why);
  if (options.out.empty()) throw UsageError("invalid option: --out is required");
  // An existing --out is replaced only when it is empty or an earlier
  // rrslam-synth output (common/atomic_file.h): the files written below.
  AtomicOutput output(options.out, AtomicOutput::Kind::kDirectory,
                      {.tool = "rrslam-synth",
                       .files = {"rgb.txt", "depth.txt", "associations.txt", "groundtruth.txt",
                                 "settings.yaml", "synth.json"},
                       .folders = {{"rgb", R"(\d+\.\d{6}\.png)"}, {"depth", R"(\d+\.\d{6}\.png)"}},
                       .record = "synth.json"});
  const fs::path dir = output.temp_path();

  const auto start = std::chrono::steady_clock::now();
  const std::string scene_name = options.scene == synth::SceneKind::kBuilding ? "building" : "room";
  spdlog::info("setting up the {} (texel size {} m, seed {})", scene_name, options.texel_size,
               options.seed);
  const SyntheticSequence sequence(options);
  const double scene_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  spdlog::info("{} set up in {:.2f} s: {} surfaces, {:.0f} MB of textures", scene_name,
               scene_seconds, sequence.scene().surfaces().size(),
               sequence.scene().TextureBytes() / 1e6);

  std::error_code ec;
  for (const char* sub : {"rgb", "depth"}) {
    if (!fs::create_directory(dir / sub, ec)) {
      throw CantCreateError((dir / sub).string() + ": cannot create folder: " + ec.message());
    }
  }

  // Frames on worker threads; each frame's files depend only on its index.
  const size_t n = sequence.size();
  const int threads = std::min<int>(ResolveThreads(options.threads), static_cast<int>(n));
  ProgressBar progress("synth", n, "frame");
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&] {
    try {
      for (size_t i = next++; i < n && !failed; i = next++) {
        const SynthFrame frame = sequence.Render(i);
        const std::string name = FormatTimestamp(frame.timestamp) + ".png";
        WritePngInside(dir / "rgb" / name, frame.color);
        WritePngInside(dir / "depth" / name, frame.depth);
        progress.Advance();
      }
    } catch (...) {
      std::lock_guard lock(error_mutex);
      if (!error) error = std::current_exception();
      failed = true;
    }
  };
  // A thread that cannot be started is a ResourceError (WorkerPool).
  WorkerPool pool(threads);
  pool.ParallelFor(static_cast<size_t>(std::max(threads, 1)), [&](size_t) { worker(); });
  progress.Finish();
  if (error) std::rethrow_exception(error);

  // Lists in the TUM layout: three header lines, then `timestamp path`.
  std::ostringstream rgb, depth, associations;
  rgb << "# color images\n# rendered by " << Producer("synth") << "\n# timestamp filename\n";
  depth << "# depth maps\n# rendered by " << Producer("synth") << "\n# timestamp filename\n";
  for (const StampedPose& pose : sequence.groundtruth()) {
    const std::string ts = FormatTimestamp(pose.timestamp);
    rgb << ts << " rgb/" << ts << ".png\n";
    depth << ts << " depth/" << ts << ".png\n";
    associations << ts << " rgb/" << ts << ".png " << ts << " depth/" << ts << ".png\n";
  }
  WriteText(dir / "rgb.txt", rgb.str());
  WriteText(dir / "depth.txt", depth.str());
  WriteText(dir / "associations.txt", associations.str());
  WriteText(dir / "groundtruth.txt",
            "# ground truth trajectory (T_world_cam, exact)\n# rendered by " + Producer("synth") +
                "\n# timestamp tx ty tz qx qy qz qw\n" +
                FormatTumTrajectory(sequence.groundtruth()));
  WriteText(dir / "settings.yaml", FormatSettings(options.MakeSettings()));

  nlohmann::ordered_json info;
  info["format"] = "rrslam-synth sequence";
  info["version"] = 1;
  info["producer"] = Producer("synth");
  info["options"] = nlohmann::ordered_json::parse(options.ToJson());
  info["duration_s"] = sequence.duration();
  if (options.trajectory == synth::TrajectoryKind::kTour) {
    // The tour repeats after this long (a shorter sequence is its first part).
    info["tour_duration_s"] = synth::BuildingTour::Get().duration();
  }
  info["depth_map_factor"] = kDepthMapFactor;
  info["world_frame"] = options.scene == synth::SceneKind::kBuilding
                            ? "metres, z up; building x in [0, 16.2], y in [0, 12.6], z in [0, 2.8]"
                            : "metres, z up; room x in [-3, 3], y in [-2.5, 2.5], z in [0, 3]";
  info["camera_frame"] = "x right, y down, z forward; depth = z";
  nlohmann::ordered_json surfaces = nlohmann::ordered_json::array();
  for (const synth::Surface& s : sequence.scene().surfaces()) surfaces.push_back(s.name);
  info["surfaces"] = surfaces;
  synth::SceneChange change = synth::SceneChange::kNone;
  synth::ParseSceneChange(options.scene_change, &change);
  info["scene_change"] = SceneChangeJson(synth::DescribeSceneChange(change));
  WriteText(dir / "synth.json", DumpJson(info, 2) + "\n");

  output.Commit();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  spdlog::info("wrote {} frames to {} in {:.1f} s ({:.1f} frames/s on {} threads)", n,
               options.out.string(), seconds, n / std::max(1e-9, seconds - scene_seconds), threads);
}

}  // namespace rrslam
