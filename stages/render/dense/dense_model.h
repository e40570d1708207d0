// `rrslam-render dense`: a dense coloured model of a saved map. The depth and
// colour images of the map's keyframes (found in the RGB-D sequence the map
// was built from, by timestamp) are fused at the keyframes' optimized poses
// into a coloured TSDF volume of OpenCV's rgbd module
// (cv::kinfu::VolumeType::COLOREDTSDF, KinectFusion's running-average TSDF
// with a colour per voxel); the volume's zero crossings are exported as a
// coloured point cloud with normals (PLY) and the volume is raycast into a
// shaded picture (PNG). Points and pixels take their colour from the
// keyframe pixels that see them (sharper than the voxels' colours, which
// OpenCV 4.6 blends with unobserved voxels; dense_model.cc explains).
//
// OpenCV 4.6's integration and export are off its own grid by a voxel along
// the volume's z and half a voxel on every axis, and its integration is
// wrong for a camera whose optical axis points along the volume's z axis;
// the volume's orientation avoids the latter and the export corrects the
// former (dense_model.cc: ChooseDenseVolumeAxes), so surfaces land where the
// depth put them (the test holds a plane to 0.15 voxel on average).
//
// Frames and units: the map's world frame, metres. Camera poses are T_world_cam
// (camera-to-world), which is also what OpenCV's Volume::integrate and
// Volume::raycast take as `cameraPose` (camera-to-world of the frame the
// volume's own pose is given in). The volume's pose maps its frame (origin
// at its corner voxel, axes R_world_volume) to the world.
//
// Thread-safety: BuildDenseModel and RunDense set OpenCV's thread count for
// their duration (cv::setNumThreads, process-wide) and restore it; do not run
// two at once.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "stages/render/keyframe_images.h"
#include "stages/render/ply.h"

namespace CLI {
class App;
}

namespace rrslam {

struct DenseOptions {
  // Map file (rrslam.map) whose keyframes are fused. Required (--map).
  std::filesystem::path map;
  // The TUM-layout RGB-D sequence the map was built from (common/dataset.h).
  // Every keyframe's timestamp must be the rgb timestamp of one of its
  // frames (within kKeyFrameTimestampTolerance, mapstore/map_data.h). Required (--sequence).
  std::filesystem::path sequence;
  // Associations file, absolute or relative to the sequence, as given to
  // rrslam-track (--associations); empty: rgb.txt paired with depth.txt.
  std::filesystem::path associations;
  // Point cloud output (PLY). Required (--out).
  std::filesystem::path out;
  // The PNG rendering of the model; empty: `out` with the extension .png
  // (--image).
  std::filesystem::path image;
  // Edge of a voxel, metres, > 0 (--voxel).
  double voxel = 0.01;
  // TSDF truncation distance, metres (--truncation). 0: 4 voxels (KinectFusion
  // uses a few voxels; about the depth noise of a Kinect at 2-3 m). Otherwise
  // at least 2.1 voxels, OpenCV's smallest band (it silently widens a
  // narrower one).
  double truncation = 0;
  // Depth beyond this many metres is ignored (--max-depth), > 0. Kinect-type
  // sensors become noisy beyond ~4 m; the bound also limits the volume.
  double max_depth = 4.0;
  // PLY as binary little-endian (default: 3x smaller and faster to read than
  // ASCII); false: ASCII (--ascii).
  bool binary = true;
  // The voxel grid may use at most this many GiB (8 bytes a voxel), in
  // (0, 16) (--max-volume-gb). The default keeps the whole process under
  // 4 GB: the grid plus images, surface points and the rendering add a few
  // hundred MB. A larger volume is refused, suggesting a --voxel that fits.
  double max_volume_gb = 3.0;
  // Width of the rendering in pixels, in [64, 8192]; the height follows the
  // camera's aspect ratio (--image-width).
  int image_width = 1280;
  // OpenCV worker threads for fusion, export and raycasting, in [1, 64]
  // (--threads).
  int threads = 2;
  // The model's frame, camera or floor (export_frame.h): the keyframes are
  // fused at their poses in it (--frame).
  std::string frame = "camera";

  // The truncation distance used: `truncation`, or 4 voxels when it is 0.
  double EffectiveTruncation() const { return truncation > 0 ? truncation : 4 * voxel; }
  // `image`, or `out` with the extension .png.
  std::filesystem::path ImagePath() const;

  // Names the first violated constraint ("--voxel = 0; must be > 0 metres").
  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};

// Binds the options to flags of the `dense` command.
void BindDenseOptions(CLI::App* command, DenseOptions* options);

// The volume's axes in the world (columns x, y, z of R_world_volume) for
// views with these camera poses: the z axis points against every view's
// optical axis where one direction can (OpenCV 4.6 integrates a view whose
// optical axis points along the volume's z wrongly; dense_model.cc has the
// details): the views' mean up direction (-y of the cameras) when every view
// looks level or down by at least a degree, else the direction of largest
// margin. `views_against` receives the number of views it could not serve.
// x is the world's x (else y) made perpendicular to z.
Eigen::Matrix3d ChooseDenseVolumeAxes(const std::vector<Rigid3d>& T_world_cams,
                                      size_t* views_against);

// Loads the images of view `index`; `with_color` false: the colour image is
// not needed (the bounds pass). Called three times per view (bounds, fusion,
// colours), from one thread.
using DenseImageLoader = std::function<KeyFrameView(size_t index, bool with_color)>;

struct DenseResult {
  size_t keyframes_fused = 0;
  size_t points = 0;                    // Surface points exported.
  size_t points_without_normal = 0;     // Dropped: no TSDF gradient there (volume border).
  size_t points_colored_by_volume = 0;  // No view sees them: the volume's colour.
  // Normals turned round: every view that sees the point saw it from behind
  // the TSDF's normal (ColorAccumulator in dense_model.cc).
  size_t normals_flipped = 0;
  // The volume's axes in the world (columns); its z axis points against the
  // views' optical axes (ChooseDenseVolumeAxes in dense_model.cc explains why).
  Eigen::Matrix3d R_world_volume = Eigen::Matrix3d::Identity();
  size_t views_against_axis = 0;     // Views no volume axis suits (fused anyway).
  Eigen::AlignedBox3d depth_bounds;  // Of the fused depth points, volume axes, metres.
  Eigen::Vector3d volume_origin = Eigen::Vector3d::Zero();  // Centre of voxel (0, 0, 0), world.
  Eigen::Vector3i resolution = Eigen::Vector3i::Zero();     // Voxels per axis.
  double voxel = 0;                                         // Metres.
  double truncation = 0;                                    // Metres.
  size_t volume_bytes = 0;                                  // Of the voxel grid.
  Rigid3d T_world_view;             // Pose of the rendering's virtual camera.
  double view_fx = 0;               // Its focal length, pixels (square pixels).
  double view_cx = 0, view_cy = 0;  // Its principal point, pixels.
  double bounds_seconds = 0;        // Reading depth for the volume bounds.
  double fuse_seconds = 0;          // Allocating the volume, reading images, integrating.
  double export_seconds = 0;        // Surface points and the raycast.
  double color_seconds = 0;         // Reading images again and colouring points and pixels.
  double write_seconds = 0;         // Files (RunDense only).

  nlohmann::ordered_json ToJson() const;
};

struct DenseModel {
  PlyCloud cloud;     // Surface points (world, metres), unit normals, colours.
  cv::Mat rendering;  // CV_8UC3 BGR picture of the model.
  DenseResult result;
};

// Fuses the views (camera poses T_world_cams, images from `load`) into a
// coloured TSDF volume sized to fit their depth points (clipped to
// options.max_depth; volume axes as ChooseDenseVolumeAxes picks them, plus the
// truncation band and two voxels), then exports its surface points with
// normals and a rendering. Colours of points and pixels: the mean of the
// views' pixels where the view's depth agrees with the point within the
// truncation distance, weighted by the squared cosine of the viewing angle;
// the volume's colour where no view sees the point. Uses options.voxel,
// truncation, max_depth, max_volume_gb, image_width and threads (not the
// paths).
//
// The rendering's viewpoint: it looks along the keyframes' mean viewing
// direction, "up" being their mean up direction, at the centre of the
// surface points (the middle of their 2%..98% range on each axis), from far
// enough back that 98% of the points are in a 66-degree field of view; then
// the focal length and principal point are set so the 1%..99% range of the
// points' projections fills 95% of the picture, centred (square pixels, the
// camera's aspect ratio). Shading: colour x
// (0.42 + 0.45 headlight + 0.25 key light from the upper left), with
// normals averaged over 5x5 pixels of the same surface, on a dark gradient.
//
// Throws UsageError when the volume would exceed options.max_volume_gb
// (naming a --voxel that fits), DataError when a view's images do not fit the
// camera or no view has depth within max_depth, AlgorithmError when the volume
// has no surface.
DenseModel BuildDenseModel(const DenseOptions& options, const KeyFrameCamera& camera,
                           const std::vector<Rigid3d>& T_world_cams, const DenseImageLoader& load);

// `rrslam-render dense`: reads the map and the sequence, builds the model,
// writes the PLY (comments: producer, options, volume) and the PNG (metadata:
// producer, options, viewpoint) atomically, and prints a summary on stdout.
// Throws UsageError (options, volume too large), NoInputError (missing map,
// sequence or image), DataError (malformed input; a keyframe whose timestamp
// is no frame of the sequence: the map was built from another sequence or
// association, so fusing it anyway would give a wrong model), CantCreateError
// (an output cannot be written).
DenseResult RunDense(const DenseOptions& options);

}  // namespace rrslam
