// rrslam-synth: renders a synthetic TUM-layout RGB-D sequence of a textured
// room with exact ground truth. See docs/synth.md.
#include <CLI/CLI.hpp>
#include <sstream>

#include "common/cli.h"
#include "stages/synth/synth.h"

namespace {

void BindSynthOptions(CLI::App& app, rrslam::SynthOptions* o) {
  app.add_option("--out", o->out,
                 "Output sequence folder (written atomically); an existing one is replaced only "
                 "when empty or an earlier rrslam-synth output (else exit 73, nothing touched)")
      ->required();
  app.add_option_function<std::string>(
         "--scene",
         [o](const std::string& name) { rrslam::synth::ParseSceneKind(name, &o->scene); },
         "Scene: standard (one furnished 6 x 5 m room) or building (six furnished rooms along a "
         "16 m corridor, walked by --trajectory tour only; no --change)")
      ->check(CLI::IsMember({"standard", "building"}))
      ->default_str(rrslam::synth::SceneKindName(o->scene));
  app.add_option_function<std::string>(
         "--trajectory",
         [o](const std::string& name) { rrslam::synth::ParseTrajectoryKind(name, &o->trajectory); },
         "Camera path: loop (closed loop, ends at its start), sweep (there and back), rotation "
         "(pan in place), shake (fast hand-held roll/pitch/yaw shaking in place, 40-140 deg/s with "
         "tremor; "
         "motion blur on by default), turn (stands looking south, turns to look north: onto the "
         "sweep's view): all in the standard room; tour (--scene building only: a walk through "
         "all its rooms and back over the corridor, 222.5 s per tour, repeated)")
      ->check(CLI::IsMember({"loop", "sweep", "rotation", "shake", "turn", "tour"}))
      ->default_str(rrslam::synth::TrajectoryKindName(o->trajectory));
  app.add_option("--frames", o->frames, "Number of frames [1, 100000]")->capture_default_str();
  app.add_option("--fps", o->fps, "Frame rate, Hz; frame i is at i / fps seconds")
      ->capture_default_str();
  app.add_option("--width", o->width, "Image width, pixels [16, 8192]")->capture_default_str();
  app.add_option("--height", o->height, "Image height, pixels [16, 8192]")->capture_default_str();
  app.add_option("--fx", o->fx, "Focal length x, pixels; 0 = 525 * width / 640")
      ->capture_default_str();
  app.add_option("--fy", o->fy, "Focal length y, pixels; 0 = 525 * height / 480")
      ->capture_default_str();
  app.add_option("--cx", o->cx, "Principal point x, pixels; 0 = 320 * width / 640 - 0.5")
      ->capture_default_str();
  app.add_option("--cy", o->cy, "Principal point y, pixels; 0 = 240 * height / 480 - 0.5")
      ->capture_default_str();
  app.add_option("--depth-noise", o->depth_noise,
                 "Depth noise k, 1/m: sigma = k * z^2 metres (Kinect); 0 = exact [0, 0.05]")
      ->capture_default_str();
  app.add_option("--depth-holes", o->depth_holes,
                 "Fraction of pixels without depth (edges, far range, grazing first) [0, 0.9]")
      ->capture_default_str();
  app.add_option("--depth-scale-error", o->depth_scale_error,
                 "Depth scale bias E: the sensor reports (1 + E) * true depth, before noise "
                 "and holes; 0.01 = 1% too far (-0.5, 0.5)")
      ->capture_default_str();
  app.add_option("--depth-scale-wander", o->depth_scale_wander,
                 "Wander W of the depth scale bias: at t seconds the sensor reports "
                 "(1 + E + W sin(2 pi t / P)) * true depth; a drift source, unlike a constant "
                 "E [0, 0.2]")
      ->capture_default_str();
  app.add_option("--depth-scale-period", o->depth_scale_period,
                 "Period P of the depth scale wander, seconds [0.1, 3600]")
      ->capture_default_str();
  app.add_option("--brightness-change", o->brightness_change,
                 "Amplitude of the exposure change: gain within 1 +- this [0, 0.9]")
      ->capture_default_str();
  // Left unset unless given, so that the trajectory chooses the default
  // (SynthOptions::MotionBlur()); a given value, 0 included, always counts.
  std::ostringstream shake_blur;
  shake_blur << rrslam::DefaultMotionBlur(rrslam::synth::TrajectoryKind::kShake);
  app.add_option_function<double>(
         "--motion-blur", [o](double pixels) { o->motion_blur = pixels; },
         "Motion blur, pixels of image motion during the exposure [0, 64]; 0 = none. Default: " +
             shake_blur.str() + " for shake, 0 for the other trajectories")
      ->default_str("0 (shake: " + shake_blur.str() + ")");
  app.add_option("--seed", o->seed, "Seed of textures, noise, holes and exposure")
      ->capture_default_str();
  app.add_option("--texel-size", o->texel_size,
                 "Texture resolution, metres per texel [0.0005, 0.05]")
      ->capture_default_str();
  // Not restricted here: SynthOptions::Check names the valid values.
  app.add_option("--change", o->scene_change,
                 "Scene edit: none (the standard room) or moved-box (the screen moves from the "
                 "table to the floor and a new crate appears; all else bit-identical; synth.json "
                 "records where); standard room only")
      ->capture_default_str();
  app.add_option("--threads", o->threads, "Worker threads; 0 = all cores (same output)")
      ->capture_default_str();
}

}  // namespace

int main(int argc, char** argv) {
  rrslam::SynthOptions options;
  return rrslam::RunTool(
      argc, argv,
      {"synth",
       "Renders a TUM-layout RGB-D sequence of a textured room or building with exact ground "
       "truth "
       "(rgb/, depth/, rgb.txt, depth.txt, associations.txt, groundtruth.txt, settings.yaml, "
       "synth.json)."},
      [&](CLI::App& app) { BindSynthOptions(app, &options); }, [&] { rrslam::RunSynth(options); });
}
