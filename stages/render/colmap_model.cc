#include "stages/render/colmap_model.h"

#include <fmt/format.h>

#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "common/atomic_file.h"
#include "common/camera.h"
#include "common/errors.h"
#include "stages/mapstore/map_join.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;

// COLMAP's camera models rrslam writes: name, id and parameter count
// (colmap/src/base/camera_models.h).
struct CameraModel {
  const char* name;
  int id;
  size_t params;
};
constexpr CameraModel kCameraModels[] = {
    {"PINHOLE", 1, 4}, {"OPENCV", 4, 8}, {"FULL_OPENCV", 6, 12}};

const CameraModel* ModelNamed(const std::string& name) {
  for (const CameraModel& m : kCameraModels) {
    if (name == m.name) return &m;
  }
  return nullptr;
}
const CameraModel* ModelWithId(int id) {
  for (const CameraModel& m : kCameraModels) {
    if (id == m.id) return &m;
  }
  return nullptr;
}

ColmapCamera CameraOf(const MapCamera& c) {
  ColmapCamera camera;
  camera.width = static_cast<uint64_t>(c.width);
  camera.height = static_cast<uint64_t>(c.height);
  const double cx = c.cx + 0.5, cy = c.cy + 0.5;  // COLMAP: (0.5, 0.5) is the first pixel's centre.
  if (c.k1 == 0 && c.k2 == 0 && c.p1 == 0 && c.p2 == 0 && c.k3 == 0) {
    camera.model = "PINHOLE";
    camera.params = {c.fx, c.fy, cx, cy};
  } else if (c.k3 == 0) {
    camera.model = "OPENCV";
    camera.params = {c.fx, c.fy, cx, cy, c.k1, c.k2, c.p1, c.p2};
  } else {
    camera.model = "FULL_OPENCV";
    camera.params = {c.fx, c.fy, cx, cy, c.k1, c.k2, c.p1, c.p2, c.k3, 0, 0, 0};
  }
  return camera;
}

// Mean distance (pixels) between where `xyz` projects and its observations.
double MeanReprojectionError(const ColmapModel& model, const PinholeCamera& camera,
                             const ColmapPoint& point) {
  if (point.track.empty()) return 0;
  const Eigen::Vector3d x(point.xyz[0], point.xyz[1], point.xyz[2]);
  double sum = 0;
  for (const auto& [image_id, index] : point.track) {
    const ColmapImage& image = model.images[image_id - 1];
    const Eigen::Vector3d x_cam = image.T_cam_world * x;
    const Eigen::Vector2d projected = camera.ProjectDistorted(x_cam) + Eigen::Vector2d(0.5, 0.5);
    sum += (projected - Eigen::Vector2d(image.points2d[index][0], image.points2d[index][1])).norm();
  }
  return sum / static_cast<double>(point.track.size());
}

template <typename T>
void Put(std::string* out, T value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// A little-endian reader over a file's bytes; DataError naming it when short.
class Bytes {
 public:
  explicit Bytes(const fs::path& path) : path_(path) {
    if (!fs::is_regular_file(path)) throw NoInputError(path.string() + ": no such file");
    data_ = ReadFileToString(path);
  }
  template <typename T>
  T Get() {
    if (pos_ + sizeof(T) > data_.size()) throw DataError(path_.string() + ": truncated");
    T value;
    std::memcpy(&value, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  std::string GetString() {
    const size_t end = data_.find('\0', pos_);
    if (end == std::string::npos) throw DataError(path_.string() + ": truncated name");
    std::string s = data_.substr(pos_, end - pos_);
    pos_ = end + 1;
    return s;
  }
  // A count of records at least `record_bytes` each: bounded by what is left.
  uint64_t GetCount(size_t record_bytes) {
    const uint64_t n = Get<uint64_t>();
    if (n > (data_.size() - pos_) / record_bytes) {
      throw DataError(path_.string() + ": count " + std::to_string(n) + " exceeds the file");
    }
    return n;
  }

 private:
  fs::path path_;
  std::string data_;
  size_t pos_ = 0;
};

std::string CamerasBinary(const ColmapModel& m) {
  std::string out;
  Put<uint64_t>(&out, m.cameras.size());
  for (const ColmapCamera& c : m.cameras) {
    Put<int32_t>(&out, static_cast<int32_t>(c.id));
    const CameraModel* model = ModelNamed(c.model);
    if (model == nullptr) throw std::invalid_argument("COLMAP camera model " + c.model);
    Put<int32_t>(&out, model->id);
    Put<uint64_t>(&out, c.width);
    Put<uint64_t>(&out, c.height);
    for (double p : c.params) Put<double>(&out, p);
  }
  return out;
}

std::string ImagesBinary(const ColmapModel& m) {
  std::string out;
  Put<uint64_t>(&out, m.images.size());
  for (const ColmapImage& im : m.images) {
    Put<int32_t>(&out, static_cast<int32_t>(im.id));
    const Eigen::Quaterniond& q = im.T_cam_world.rotation;
    for (double v : {q.w(), q.x(), q.y(), q.z()}) Put<double>(&out, v);
    for (int i = 0; i < 3; ++i) Put<double>(&out, im.T_cam_world.translation[i]);
    Put<int32_t>(&out, static_cast<int32_t>(im.camera_id));
    out.append(im.name);
    out.push_back('\0');
    Put<uint64_t>(&out, im.points2d.size());
    for (size_t i = 0; i < im.points2d.size(); ++i) {
      Put<double>(&out, im.points2d[i][0]);
      Put<double>(&out, im.points2d[i][1]);
      Put<int64_t>(&out, im.point3d_ids[i]);
    }
  }
  return out;
}

std::string PointsBinary(const ColmapModel& m) {
  std::string out;
  Put<uint64_t>(&out, m.points.size());
  for (const ColmapPoint& p : m.points) {
    Put<uint64_t>(&out, p.id);
    for (double v : p.xyz) Put<double>(&out, v);
    for (uint8_t c : p.rgb) Put<uint8_t>(&out, c);
    Put<double>(&out, p.error);
    Put<uint64_t>(&out, p.track.size());
    for (const auto& [image, index] : p.track) {
      Put<int32_t>(&out, static_cast<int32_t>(image));
      Put<int32_t>(&out, static_cast<int32_t>(index));
    }
  }
  return out;
}

std::string CamerasText(const ColmapModel& m) {
  std::string out =
      "# Camera list with one line of data per camera:\n"
      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  out += fmt::format("# Number of cameras: {}\n", m.cameras.size());
  for (const ColmapCamera& c : m.cameras) {
    out += fmt::format("{} {} {} {}", c.id, c.model, c.width, c.height);
    for (double p : c.params) out += fmt::format(" {:.17g}", p);
    out += "\n";
  }
  return out;
}

std::string ImagesText(const ColmapModel& m) {
  std::string out =
      "# Image list with two lines of data per image:\n"
      "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      "#   POINTS2D[] as (X, Y, POINT3D_ID)\n";
  out += fmt::format("# Number of images: {}\n", m.images.size());
  for (const ColmapImage& im : m.images) {
    const Eigen::Quaterniond& q = im.T_cam_world.rotation;
    const Eigen::Vector3d& t = im.T_cam_world.translation;
    out += fmt::format("{} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {} {}\n", im.id,
                       q.w(), q.x(), q.y(), q.z(), t.x(), t.y(), t.z(), im.camera_id, im.name);
    for (size_t i = 0; i < im.points2d.size(); ++i) {
      out += fmt::format("{}{:.9g} {:.9g} {}", i == 0 ? "" : " ", im.points2d[i][0],
                         im.points2d[i][1], im.point3d_ids[i]);
    }
    out += "\n";
  }
  return out;
}

std::string PointsText(const ColmapModel& m) {
  std::string out =
      "# 3D point list with one line of data per point:\n"
      "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n";
  out += fmt::format("# Number of points: {}\n", m.points.size());
  for (const ColmapPoint& p : m.points) {
    out += fmt::format("{} {:.17g} {:.17g} {:.17g} {} {} {} {:.9g}", p.id, p.xyz[0], p.xyz[1],
                       p.xyz[2], p.rgb[0], p.rgb[1], p.rgb[2], p.error);
    for (const auto& [image, index] : p.track) out += fmt::format(" {} {}", image, index);
    out += "\n";
  }
  return out;
}

// The data lines of a COLMAP text file ('#' comments and blank lines out).
std::vector<std::string> DataLines(const fs::path& path, bool keep_blank) {
  if (!fs::is_regular_file(path)) throw NoInputError(path.string() + ": no such file");
  std::istringstream in(ReadFileToString(path));
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line[0] == '#') continue;
    if (line.empty() && !keep_blank) continue;
    lines.push_back(line);
  }
  return lines;
}

void ReadText(const fs::path& dir, ColmapModel* m) {
  const auto fail = [](const fs::path& p, const std::string& line) {
    throw DataError(p.string() + ": malformed line \"" + line.substr(0, 80) + "\"");
  };
  const fs::path cameras = dir / "cameras.txt", images = dir / "images.txt",
                 points = dir / "points3D.txt";
  for (const std::string& line : DataLines(cameras, false)) {
    std::istringstream s(line);
    ColmapCamera c;
    if (!(s >> c.id >> c.model >> c.width >> c.height)) fail(cameras, line);
    for (double p; s >> p;) c.params.push_back(p);
    m->cameras.push_back(c);
  }
  const std::vector<std::string> lines = DataLines(images, true);
  for (size_t i = 0; i + 1 < lines.size(); i += 2) {
    std::istringstream s(lines[i]), p(lines[i + 1]);
    ColmapImage im;
    double qw, qx, qy, qz, tx, ty, tz;
    if (!(s >> im.id >> qw >> qx >> qy >> qz >> tx >> ty >> tz >> im.camera_id >> im.name)) {
      fail(images, lines[i]);
    }
    im.T_cam_world = Rigid3d(Eigen::Quaterniond(qw, qx, qy, qz), Eigen::Vector3d(tx, ty, tz));
    double x, y;
    for (int64_t id; p >> x >> y >> id;) {
      im.points2d.push_back({x, y});
      im.point3d_ids.push_back(id);
    }
    m->images.push_back(std::move(im));
  }
  for (const std::string& line : DataLines(points, false)) {
    std::istringstream s(line);
    ColmapPoint p;
    int r, g, b;
    if (!(s >> p.id >> p.xyz[0] >> p.xyz[1] >> p.xyz[2] >> r >> g >> b >> p.error)) {
      fail(points, line);
    }
    p.rgb = {static_cast<uint8_t>(r), static_cast<uint8_t>(g), static_cast<uint8_t>(b)};
    for (uint32_t image, index; s >> image >> index;) p.track.push_back({image, index});
    m->points.push_back(std::move(p));
  }
}

void ReadBinary(const fs::path& dir, ColmapModel* m) {
  Bytes cameras(dir / "cameras.bin");
  for (uint64_t n = cameras.GetCount(24), i = 0; i < n; ++i) {
    ColmapCamera c;
    c.id = static_cast<uint32_t>(cameras.Get<int32_t>());
    const CameraModel* model = ModelWithId(cameras.Get<int32_t>());
    if (model == nullptr) {
      throw DataError((dir / "cameras.bin").string() + ": unknown camera model");
    }
    c.model = model->name;
    c.width = cameras.Get<uint64_t>();
    c.height = cameras.Get<uint64_t>();
    for (size_t k = 0; k < model->params; ++k) c.params.push_back(cameras.Get<double>());
    m->cameras.push_back(c);
  }
  Bytes images(dir / "images.bin");
  for (uint64_t n = images.GetCount(64), i = 0; i < n; ++i) {
    ColmapImage im;
    im.id = static_cast<uint32_t>(images.Get<int32_t>());
    double v[7];
    for (double& x : v) x = images.Get<double>();
    im.T_cam_world =
        Rigid3d(Eigen::Quaterniond(v[0], v[1], v[2], v[3]), Eigen::Vector3d(v[4], v[5], v[6]));
    im.camera_id = static_cast<uint32_t>(images.Get<int32_t>());
    im.name = images.GetString();
    for (uint64_t k = 0, np = images.GetCount(24); k < np; ++k) {
      const double x = images.Get<double>(), y = images.Get<double>();
      im.points2d.push_back({x, y});
      im.point3d_ids.push_back(images.Get<int64_t>());
    }
    m->images.push_back(std::move(im));
  }
  Bytes points(dir / "points3D.bin");
  for (uint64_t n = points.GetCount(43), i = 0; i < n; ++i) {
    ColmapPoint p;
    p.id = points.Get<uint64_t>();
    for (double& x : p.xyz) x = points.Get<double>();
    for (uint8_t& c : p.rgb) c = points.Get<uint8_t>();
    p.error = points.Get<double>();
    for (uint64_t k = 0, nt = points.GetCount(8); k < nt; ++k) {
      const auto image = static_cast<uint32_t>(points.Get<int32_t>());
      const auto index = static_cast<uint32_t>(points.Get<int32_t>());
      p.track.push_back({image, index});
    }
    m->points.push_back(std::move(p));
  }
}

}  // namespace

ColmapModel ColmapModelOf(const MapData& map, const std::vector<std::string>& image_names,
                          const std::vector<std::array<uint8_t, 3>>& colours) {
  if (image_names.size() != map.keyframes.size() || colours.size() != map.map_points.size()) {
    throw std::invalid_argument("ColmapModelOf: one name per keyframe and colour per point");
  }
  ColmapModel model;
  model.cameras.push_back(CameraOf(map.camera));
  const MapCamera& c = map.camera;
  const PinholeCamera camera(c.fx, c.fy, c.cx, c.cy, c.width, c.height,
                             Distortion{c.k1, c.k2, c.p1, c.p2, c.k3});
  std::unordered_map<uint64_t, int64_t> point_id;  // Map point id -> COLMAP id.
  for (size_t i = 0; i < map.map_points.size(); ++i) {
    point_id.emplace(map.map_points[i].id, static_cast<int64_t>(i + 1));
  }
  std::unordered_map<uint64_t, uint32_t> image_id;  // Keyframe id -> COLMAP id.
  for (size_t k = 0; k < map.keyframes.size(); ++k) {
    const KeyFrameRecord& kf = map.keyframes[k];
    ColmapImage image;
    image.id = static_cast<uint32_t>(k + 1);
    image.T_cam_world = RigidOf(kf.T_cam_world);
    image.name = image_names[k];
    for (size_t i = 0; i < kf.keypoints.size(); ++i) {
      image.points2d.push_back({kf.keypoints[i].pixel.x() + 0.5, kf.keypoints[i].pixel.y() + 0.5});
      const uint64_t p = kf.map_point_ids[i];
      image.point3d_ids.push_back(p == kNoId ? -1 : point_id.at(p));
    }
    image_id.emplace(kf.id, image.id);
    model.images.push_back(std::move(image));
  }
  for (size_t i = 0; i < map.map_points.size(); ++i) {
    const MapPointRecord& r = map.map_points[i];
    ColmapPoint p;
    p.id = i + 1;
    p.xyz = {r.position[0], r.position[1], r.position[2]};
    p.rgb = colours[i];
    for (const auto& [kf, index] : r.observations) p.track.push_back({image_id.at(kf), index});
    p.error = MeanReprojectionError(model, camera, p);
    model.points.push_back(std::move(p));
  }
  return model;
}

void WriteColmapModel(const ColmapModel& model, const fs::path& dir, bool binary) {
  if (binary) {
    WriteFileAtomically(dir / "cameras.bin", CamerasBinary(model));
    WriteFileAtomically(dir / "images.bin", ImagesBinary(model));
    WriteFileAtomically(dir / "points3D.bin", PointsBinary(model));
  } else {
    WriteFileAtomically(dir / "cameras.txt", CamerasText(model));
    WriteFileAtomically(dir / "images.txt", ImagesText(model));
    WriteFileAtomically(dir / "points3D.txt", PointsText(model));
  }
}

ColmapModel ReadColmapModel(const fs::path& dir, bool binary) {
  ColmapModel model;
  if (binary) {
    ReadBinary(dir, &model);
  } else {
    ReadText(dir, &model);
  }
  return model;
}

}  // namespace rrslam
