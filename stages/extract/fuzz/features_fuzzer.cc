// libFuzzer target: the features file reader (rrslam.features, HDF5).
//
// Each input describes a features file (features_schema.h), which
// common/fuzz/h5_image_builder.h writes as an HDF5 file image in memory,
// keeping or damaging each object as the input decides; the reader then
// opens the image's bytes (ReadFeaturesFileImage and
// ReadFeatureDescriptorsImage, through OpenH5FileImage's core driver: no file
// is written), so the mutations reach the root attribute checks and the
// schema and consistency checks of features_file.cc and h5io.cc. (Why not
// mutate the file's bytes themselves: see h5_image_builder.h. With
// RRSLAM_FUZZ_H5_RAW=1 in the environment the input is the file image
// itself, to fuzz libhdf5's parser; seeds in fuzz/corpus_h5.)
//
// Any rrslam::Error is an accepted rejection; anything else (a crash, a
// sanitizer report, an H5::Exception or another exception, a broken
// property) is a finding. Properties of an accepted file: every frame's
// keypoint range lies inside the keypoints, descriptors parallel the
// keypoints, and the descriptors read with a stride are those of the frames
// it selects.
//
// libhdf5 itself is not instrumented: the sanitizers see its memory accesses
// only through the C library calls they intercept (memcpy, strlen, ...).
#include <H5Cpp.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "common/errors.h"
#include "common/fuzz/check.h"
#include "common/fuzz/h5_fuzz_main.h"
#include "stages/extract/features_file.h"
#include "stages/extract/fuzz/features_schema.h"

namespace rrslam::fuzz {

std::vector<H5Object> TargetObjects(FuzzInput& in) { return FeaturesObjects(in); }

void TargetExercise(std::span<const uint8_t> bytes) {
  rrslam::FeaturesFile f;
  try {
    f = rrslam::ReadFeaturesFileImage(bytes, "fuzz-input");
  } catch (const rrslam::Error&) {
    // The descriptors alone may still read (they need fewer datasets).
    try {
      (void)rrslam::ReadFeatureDescriptorsImage(bytes, "fuzz-input", 2);
    } catch (const rrslam::Error&) {
    }
    return;
  }
  Check(f.descriptors.size() == f.keypoints.size());
  uint64_t previous_end = 0;
  for (size_t i = 0; i < f.num_frames(); ++i) {
    const rrslam::FrameRecord& r = f.frames[i];
    Check(r.keypoint_begin == previous_end && r.keypoint_begin <= r.keypoint_end &&
          r.keypoint_end <= f.keypoints.size());
    Check(f.FrameKeypoints(i).size() == f.FrameDescriptors(i).size());
    previous_end = r.keypoint_end;
  }
  Check(previous_end == f.keypoints.size());
  for (size_t stride : {1, 2}) {
    const std::vector<rrslam::OrbDescriptor> d =
        rrslam::ReadFeatureDescriptorsImage(bytes, "fuzz-input", stride);  // Must not throw.
    size_t at = 0;
    for (size_t i = 0; i < f.num_frames(); i += stride) {
      for (const rrslam::OrbDescriptor& x : f.FrameDescriptors(i)) {
        Check(at < d.size() && std::memcmp(x.bytes, d[at++].bytes, 32) == 0);
      }
    }
    Check(at == d.size());
  }
}

}  // namespace rrslam::fuzz
