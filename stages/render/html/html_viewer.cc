#include "stages/render/html/html_viewer.h"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <string_view>

#include "common/atomic_file.h"
#include "common/cli.h"
#include "common/errors.h"
#include "stages/render/export_frame.h"
#include "stages/render/html/viewer_script.h"

namespace rrslam {
namespace {

// The page's data are typed arrays read back by the browser in its own byte
// order, which is little-endian on every platform browsers run on.
static_assert(std::endian::native == std::endian::little, "the page data are little-endian");

bool Fail(std::string* why, const std::string& text) {
  if (why != nullptr) *why = text;
  return false;
}

std::string Base64(const void* data, size_t size) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* bytes = static_cast<const uint8_t*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 3 <= size; i += 3) {
    const uint32_t v = (bytes[i] << 16) | (bytes[i + 1] << 8) | bytes[i + 2];
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == size) {
    const uint32_t v = bytes[i] << 16;
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == size) {
    const uint32_t v = (bytes[i] << 16) | (bytes[i + 1] << 8);
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

template <typename T>
std::string Base64(const std::vector<T>& values) {
  return Base64(values.data(), values.size() * sizeof(T));
}

void AppendPosition(const Eigen::Vector3d& p, std::vector<float>* out) {
  out->push_back(static_cast<float>(p.x()));
  out->push_back(static_cast<float>(p.y()));
  out->push_back(static_cast<float>(p.z()));
}

// `text` with each character that has an entry in `table` replaced by it.
std::string Escape(std::string_view text,
                   std::initializer_list<std::pair<char, std::string_view>> table) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    const auto* entry =
        std::find_if(table.begin(), table.end(), [c](const auto& e) { return e.first == c; });
    if (entry == table.end()) {
      out += c;
    } else {
      out += entry->second;
    }
  }
  return out;
}

std::string EscapeHtml(std::string_view text) {
  return Escape(text,
                {{'&', "&amp;"}, {'<', "&lt;"}, {'>', "&gt;"}, {'"', "&quot;"}, {'\'', "&#39;"}});
}

// JSON that can sit inside <script>: '<', '>' and '&' only occur in JSON
// strings, where their \u escapes mean the same, so no "</script>" or "<!--"
// can end the element early.
std::string ScriptSafeJson(const nlohmann::ordered_json& json) {
  return Escape(json.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace),
                {{'<', "\\u003c"}, {'>', "\\u003e"}, {'&', "\\u0026"}});
}

// "folder/file" of a path (enough to tell inputs apart in the legend).
std::string ShortName(const std::filesystem::path& path) {
  const std::filesystem::path parent = path.parent_path().filename();
  return parent.empty() ? path.filename().string() : (parent / path.filename()).string();
}

// Each undirected edge of symmetric per-keyframe lists once: (index, index).
template <typename GetIds>
std::vector<uint32_t> UndirectedEdges(const MapScene& scene, GetIds ids_of) {
  std::vector<uint32_t> edges;
  for (size_t i = 0; i < scene.keyframes.size(); ++i) {
    const SceneKeyFrame& kf = scene.keyframes[i];
    for (const uint64_t other : ids_of(kf)) {
      if (other <= kf.id) continue;
      if (const auto j = scene.FindKeyFrame(other)) {
        edges.push_back(static_cast<uint32_t>(i));
        edges.push_back(static_cast<uint32_t>(*j));
      }
    }
  }
  return edges;
}

constexpr char kStyle[] = R"css(
html,body{margin:0;height:100%;overflow:hidden;background:#14171c;color:#e3e6ea;
  font:12px/1.4 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif}
#rrslam-canvas{position:fixed;inset:0;display:block;outline:none}
#rrslam-overlay{position:fixed;top:10px;left:10px;max-width:min(300px,calc(100% - 40px));
  max-height:calc(100% - 40px);overflow:auto;padding:8px 10px;border-radius:6px;
  background:rgba(20,23,28,.85);border:1px solid #2e333b}
html.rr-hide-panel #rrslam-overlay{display:none}
.rr-title{font-weight:600;font-size:14px;overflow-wrap:anywhere}
.rr-meta{color:#9aa3ae;overflow-wrap:anywhere}
.rr-counts{margin:4px 0}
.rr-legend{margin:6px 0 4px}
.rr-entry{display:flex;align-items:center;gap:6px;cursor:pointer;user-select:none}
.rr-swatch{display:inline-block;width:18px;height:4px;border-radius:2px;flex:none}
.rr-caption,.rr-help{color:#9aa3ae;font-size:11px}
.rr-help{margin-top:6px}
.rr-colorbar{display:flex;align-items:center;gap:6px;font-size:11px}
.rr-gradient{flex:1;height:8px;border-radius:2px}
.rr-error{color:#ff8a80;margin-top:6px}
)css";

}  // namespace

// ---------------------------------------------------------------------------
// Options

bool HtmlOptions::Check(std::string* why) const {
  if (map.empty()) return Fail(why, "map: a map file (--map) is required");
  if (out.empty()) return Fail(why, "out: an output file (--out) is required");
  for (const auto& path : gt) {
    if (path.empty()) return Fail(why, "gt: an empty trajectory path");
  }
  for (const auto& path : est) {
    if (path.empty()) return Fail(why, "est: an empty trajectory path");
  }
  std::vector<std::filesystem::path> inputs = {map};
  inputs.insert(inputs.end(), gt.begin(), gt.end());
  inputs.insert(inputs.end(), est.begin(), est.end());
  const auto same_file = [](const std::filesystem::path& a, const std::filesystem::path& b) {
    return std::filesystem::absolute(a).lexically_normal() ==
           std::filesystem::absolute(b).lexically_normal();
  };
  for (const auto& input : inputs) {
    if (same_file(input, out)) {
      return Fail(why, "out = " + out.string() + "; must not be an input file");
    }
  }
  if (title.find_first_of("\r\n") != std::string::npos) {
    return Fail(why, "title: must be one line");
  }
  return CheckFrameName(frame, why);
}

nlohmann::ordered_json HtmlOptions::ToJson() const {
  nlohmann::ordered_json j;
  j["map"] = map.string();
  j["gt"] = nlohmann::ordered_json::array();
  for (const auto& path : gt) j["gt"].push_back(path.string());
  j["est"] = nlohmann::ordered_json::array();
  for (const auto& path : est) j["est"].push_back(path.string());
  j["out"] = out.string();
  j["title"] = title;
  j["frame"] = frame;
  return j;
}

void BindHtmlOptions(CLI::App* command, HtmlOptions* options) {
  command->add_option("--map", options->map, "Map file (rrslam.map, rrslam-track --save-map)")
      ->required();
  command->add_option("--out", options->out, "HTML file to write (one self-contained page)")
      ->required();
  command->add_option("--gt", options->gt,
                      "Ground truth (TUM), aligned rigidly to the map's keyframes; repeatable");
  command->add_option("--est", options->est,
                      "Trajectory (TUM) already in the map's frame, e.g. CameraTrajectory.txt; "
                      "repeatable");
  command->add_option("--title", options->title, "Page title (default: the map's file name)");
  AddFrameOption(command, &options->frame);
}

// ---------------------------------------------------------------------------
// Page

Eigen::Matrix3d ViewFromMap(const MapScene& scene) {
  Eigen::Vector3d up_sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d forward_sum = Eigen::Vector3d::Zero();
  for (const SceneKeyFrame& kf : scene.keyframes) {
    const Eigen::Matrix3d R_world_cam = kf.T_world_cam.RotationMatrix();
    up_sum -= R_world_cam.col(1);  // Image rows grow downwards: the camera's up is -y.
    forward_sum += R_world_cam.col(2);
  }
  const double n = std::max<double>(1.0, static_cast<double>(scene.keyframes.size()));
  // A mean shorter than 0.3: the cameras disagree (on up: a random test map;
  // on forward: a scan all around a room), and the map's own axis stands in.
  Eigen::Vector3d up = up_sum / n;
  up = up.norm() < 0.3 ? Eigen::Vector3d(0, -1, 0) : up.normalized();
  if (scene.up) up = scene.up->normalized();
  auto horizontal = [&up](const Eigen::Vector3d& v) { return v - v.dot(up) * up; };
  Eigen::Vector3d forward = horizontal(forward_sum / n);
  if (forward.norm() < 0.3) forward = horizontal(Eigen::Vector3d::UnitZ());
  if (forward.norm() < 0.3) forward = horizontal(Eigen::Vector3d::UnitX());
  forward.normalize();
  Eigen::Matrix3d R_view_map;
  R_view_map.row(0) = forward.cross(up).normalized();  // Right.
  R_view_map.row(1) = up;
  R_view_map.row(2) = -forward;  // Towards the eye, as three.js cameras look along -z.
  return R_view_map;
}

std::string_view ViewerScript() {
  return {reinterpret_cast<const char*>(html_internal::kViewerScript),
          html_internal::kViewerScriptSize};
}

std::string BuildViewerHtml(
    const MapScene& scene,
    const std::vector<std::pair<std::string, Trajectory>>& trajectories_in_map_frame,
    const std::string& title, const std::string& producer, const nlohmann::ordered_json& options) {
  std::vector<float> points;
  points.reserve(3 * scene.points.size());
  size_t loaded_points = 0;
  for (const ScenePoint& p : scene.points) {
    AppendPosition(p.position, &points);
    loaded_points += p.loaded ? 1 : 0;
  }
  std::vector<float> poses;
  poses.reserve(12 * scene.keyframes.size());
  std::vector<uint8_t> keyframe_loaded;
  size_t loaded_keyframes = 0;
  for (const SceneKeyFrame& kf : scene.keyframes) {
    const Eigen::Matrix<double, 3, 4> m = kf.T_world_cam.ToMatrix3x4();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) poses.push_back(static_cast<float>(m(r, c)));
    }
    keyframe_loaded.push_back(kf.loaded ? 1 : 0);
    loaded_keyframes += kf.loaded ? 1 : 0;
  }
  std::vector<float> keyframe_trajectory;
  for (const StampedPose& pose : scene.KeyFrameTrajectory()) {
    AppendPosition(pose.T_world_cam.translation, &keyframe_trajectory);
  }
  const std::vector<uint32_t> loop_edges =
      UndirectedEdges(scene, [](const SceneKeyFrame& kf) { return kf.loop_edges; });
  size_t covisibility_edges = 0;
  for (const SceneKeyFrame& kf : scene.keyframes) {
    for (const auto& [other, weight] : kf.connections) covisibility_edges += other > kf.id ? 1 : 0;
  }

  const Eigen::Matrix3d R_view_map = ViewFromMap(scene);
  nlohmann::ordered_json data;
  data["format"] = "rrslam.viewer";
  data["version"] = 1;
  data["title"] = title;
  data["map"] = scene.source;
  data["producer"] = producer;
  data["options"] = options;
  data["counts"] = {{"points", scene.points.size()},
                    {"keyframes", scene.keyframes.size()},
                    {"loaded_points", loaded_points},
                    {"loaded_keyframes", loaded_keyframes},
                    {"covisibility_edges", covisibility_edges},
                    {"loop_edges", loop_edges.size() / 2},
                    {"trajectories", trajectories_in_map_frame.size()}};
  const MapCamera& cam = scene.camera;
  data["camera"] = {{"fx", cam.fx}, {"fy", cam.fy},       {"cx", cam.cx},
                    {"cy", cam.cy}, {"width", cam.width}, {"height", cam.height}};
  data["view_from_map"] = nlohmann::ordered_json::array();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) data["view_from_map"].push_back(R_view_map(r, c));
  }
  data["points"] = Base64(points);
  data["keyframe_poses"] = Base64(poses);
  if (scene.has_loaded_part) data["keyframe_loaded"] = Base64(keyframe_loaded);
  data["keyframe_trajectory"] = Base64(keyframe_trajectory);
  data["loop_edges"] = Base64(loop_edges);
  data["trajectories"] = nlohmann::ordered_json::array();
  for (const auto& [name, trajectory] : trajectories_in_map_frame) {
    std::vector<float> positions;
    positions.reserve(3 * trajectory.size());
    for (const StampedPose& pose : trajectory) {
      AppendPosition(pose.T_world_cam.translation, &positions);
    }
    data["trajectories"].push_back(
        {{"name", name}, {"poses", trajectory.size()}, {"positions", Base64(positions)}});
  }

  // The counts, in the page itself (readable without the script).
  std::string counts = std::to_string(scene.points.size()) + " map points";
  if (scene.has_loaded_part) counts += " (" + std::to_string(loaded_points) + " loaded)";
  counts += " · " + std::to_string(scene.keyframes.size()) + " keyframes";
  if (scene.has_loaded_part) counts += " (" + std::to_string(loaded_keyframes) + " loaded)";
  counts += " · " + std::to_string(covisibility_edges) + " covisibility edges · " +
            std::to_string(loop_edges.size() / 2) + " loop edges";
  if (!trajectories_in_map_frame.empty()) {
    const size_t n = trajectories_in_map_frame.size();
    counts += " · " + std::to_string(n) + (n == 1 ? " trajectory" : " trajectories");
  }

  const std::string_view script = ViewerScript();
  std::string html;
  html.reserve(script.size() + 65536 + 2 * sizeof(float) * (points.size() + poses.size()));
  html += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  html += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  // Nothing may be loaded from anywhere: the page is whole as written.
  html +=
      "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; "
      "script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data: blob:\">\n";
  html += "<meta name=\"generator\" content=\"" + EscapeHtml(producer) + "\">\n";
  html += "<title>" + EscapeHtml(title) + " · rrslam viewer</title>\n";
  html += "<style>" + std::string(kStyle) + "</style>\n</head>\n<body>\n";
  html += "<div id=\"rrslam-overlay\">\n";
  html += "<div class=\"rr-title\">" + EscapeHtml(title) + "</div>\n";
  html += "<div class=\"rr-meta\">map: " + EscapeHtml(scene.source) + "</div>\n";
  html += "<div class=\"rr-meta\">made by " + EscapeHtml(producer) + "</div>\n";
  html += "<div class=\"rr-counts\">" + counts + "</div>\n";
  html += "<noscript><div class=\"rr-error\">The 3D view needs JavaScript.</div></noscript>\n";
  html += "</div>\n";
  html += "<script type=\"application/json\" id=\"rrslam-data\">" + ScriptSafeJson(data) +
          "</script>\n";
  html += "<script>";
  html += script;
  html += "</script>\n</body>\n</html>\n";
  return html;
}

void RunHtml(const HtmlOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const FramedMap framed = LoadMapInFrame(options.map, options.frame);
  const MapScene& scene = framed.scene;
  spdlog::info("{}: {} map points, {} keyframes", options.map.string(), scene.points.size(),
               scene.keyframes.size());
  std::vector<std::pair<std::string, Trajectory>> trajectories;
  for (const auto& path : options.gt) {
    const Trajectory gt = ReadTumTrajectory(path);
    trajectories.emplace_back("ground truth " + ShortName(path),
                              ExpressInMapFrame(gt, scene, path.string()));
    spdlog::info("{}: {} poses, aligned to the map's keyframes", path.string(), gt.size());
  }
  for (const auto& path : options.est) {
    Trajectory est = ReadTumTrajectory(path);
    if (framed.T_floor_map) {
      for (StampedPose& pose : est) pose.T_world_cam = *framed.T_floor_map * pose.T_world_cam;
    }
    trajectories.emplace_back(ShortName(path), std::move(est));
    spdlog::info("{}: {} poses", path.string(), trajectories.back().second.size());
  }
  const std::string title = options.title.empty() ? options.map.filename().string() : options.title;
  const std::string html =
      BuildViewerHtml(scene, trajectories, title, Producer("render"), options.ToJson());
  WriteFileAtomically(options.out, html);
  spdlog::info("wrote {} ({} bytes)", options.out.string(), html.size());
}

}  // namespace rrslam
