// Vocabulary benchmark: load times of the DBoW2 text and the binary format
// (warm page cache), and the BoW transform of 1000 descriptors with the
// feature vector. Prints `key value` lines (seconds) for bench/vocab/run.sh.
//
// Usage: vocab_bench VOC.txt VOC.rrv [FEATURES.h5]
// The 1000 descriptors are those of the first frame(s) of FEATURES.h5 when
// given (real ORB descriptors), else seeded random ones.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "common/binary_header.h"
#include "stages/extract/features_file.h"
#include "stages/vocab/vocabulary.h"

namespace {

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Reads a whole file once so that it is in the page cache.
void Warm(const char* path) {
  const rrslam::MappedFile file(path);
  uint64_t sum = 0;
  const auto bytes = file.bytes();
  for (size_t i = 0; i < bytes.size(); i += 4096) sum += bytes[i];
  if (sum == 1) std::printf("#\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s VOC.txt VOC.rrv [FEATURES.h5]\n", argv[0]);
    return 64;
  }
  Warm(argv[1]);
  Warm(argv[2]);

  std::vector<double> text_times;
  size_t nodes = 0;
  for (int i = 0; i < 5; ++i) {
    const auto t = Clock::now();
    const rrslam::Vocabulary v = rrslam::Vocabulary::Load(argv[1]);
    text_times.push_back(Since(t));
    nodes = v.num_nodes();
  }
  std::vector<double> binary_times;
  for (int i = 0; i < 30; ++i) {
    const auto t = Clock::now();
    const rrslam::Vocabulary v = rrslam::Vocabulary::Load(argv[2]);
    binary_times.push_back(Since(t));
  }

  const rrslam::Vocabulary voc = rrslam::Vocabulary::Load(argv[2]);
  std::vector<rrslam::OrbDescriptor> descriptors;
  if (argc > 3) {
    const rrslam::FeaturesFile f = rrslam::ReadFeaturesFile(argv[3]);
    for (size_t frame = 0; frame < f.num_frames() && descriptors.size() < 1000; ++frame) {
      for (const auto& d : f.FrameDescriptors(frame)) {
        if (descriptors.size() < 1000) descriptors.push_back(d);
      }
    }
  }
  std::mt19937_64 rng(7);
  while (descriptors.size() < 1000) {
    rrslam::OrbDescriptor d;
    for (auto& b : d.bytes) b = static_cast<uint8_t>(rng());
    descriptors.push_back(d);
  }
  rrslam::BowVector bow;
  rrslam::FeatureVector fv;
  const auto first = Clock::now();
  voc.Transform(descriptors, &bow, &fv, 4);
  const double first_transform = Since(first);
  std::vector<double> transform_times;
  for (int i = 0; i < 300; ++i) {
    const auto t = Clock::now();
    voc.Transform(descriptors, &bow, &fv, 4);
    transform_times.push_back(Since(t));
  }

  std::printf("nodes %zu\n", nodes);
  std::printf("words %zu\n", voc.num_words());
  std::printf("text_load_median_s %.4f\n", Median(text_times));
  std::printf("text_load_min_s %.4f\n", *std::min_element(text_times.begin(), text_times.end()));
  std::printf("binary_load_median_s %.5f\n", Median(binary_times));
  std::printf("binary_load_min_s %.5f\n",
              *std::min_element(binary_times.begin(), binary_times.end()));
  std::printf("transform_1000_median_s %.6f\n", Median(transform_times));
  std::printf("transform_1000_first_s %.6f\n", first_transform);
  std::printf("transform_words %zu\n", bow.size());
  std::printf("transform_fv_nodes %zu\n", fv.size());
  std::printf("descriptors_source %s\n", argc > 3 ? "features" : "random");
  return 0;
}
