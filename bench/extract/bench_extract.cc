// Extraction time per frame of rrslam's ORB extractor beside OpenCV's cv::ORB
// with the same feature count, scale factor and levels, on preloaded frames of
// a real sequence (image loading is not timed). Run by `make bench-extract`.
//
//   bench_extract --sequence DIR --settings YAML [--frames N] [--warmup N]
//
// Every frame is extracted by each variant in turn (the order rotates from
// frame to frame), so slow drifts of the machine affect all variants alike.
// Prints a plain-text report on stdout.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <numeric>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <string>
#include <vector>

#include "common/cli.h"
#include "common/dataset.h"
#include "common/errors.h"
#include "common/progress.h"
#include "common/settings.h"
#include "stages/extract/orb_extractor.h"

namespace {

using rrslam::Keypoint;
using rrslam::OrbDescriptor;

struct Variant {
  Variant(std::string id_, std::string name_, std::function<size_t(const cv::Mat&)> run_)
      : id(std::move(id_)), name(std::move(name_)), run(std::move(run_)) {}
  std::string id;  // Short name for --variants.
  std::string name;
  std::function<size_t(const cv::Mat&)> run;  // Returns the number of features.
  std::vector<double> ms;
  std::vector<size_t> counts;
};

double Percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const double pos = p * (v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  const double f = pos - i;
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

struct BenchOptions {
  std::string sequence;
  std::string settings;
  int frames = 300;
  int warmup = 10;
  std::vector<std::string> variants;  // Empty: all.
};

void RunBench(const BenchOptions& options) {
  const rrslam::Settings settings = rrslam::ReadSettings(options.settings);
  const rrslam::RgbdSequence sequence = rrslam::RgbdSequence::Open(options.sequence);
  const size_t n = std::min<size_t>(sequence.size(), static_cast<size_t>(options.frames));
  if (n == 0) throw rrslam::DataError(options.sequence + ": no frames");
  std::vector<cv::Mat> images(n);
  {
    rrslam::ProgressBar progress("load", n, "frame");
    for (size_t i = 0; i < n; ++i) {
      images[i] = sequence.LoadGray(i);
      progress.Advance();
    }
  }
  const rrslam::OrbSettings& orb = settings.orb;

  rrslam::OrbExtractor ours1(orb, 1);
  rrslam::OrbExtractor ours2(orb, 2);
  cv::Ptr<cv::ORB> cv_orb =
      cv::ORB::create(orb.n_features, static_cast<float>(orb.scale_factor), orb.n_levels, 31, 0, 2,
                      cv::ORB::HARRIS_SCORE, 31, orb.ini_th_fast);
  std::vector<Keypoint> kps;
  std::vector<OrbDescriptor> descs;
  std::vector<cv::KeyPoint> cv_kps;
  cv::Mat cv_descs;
  const int cv_threads = cv::getNumThreads();
  std::vector<Variant> variants{
      {"rrslam2", "rrslam OrbExtractor, 2 threads",
       [&](const cv::Mat& im) {
         ours2.Extract(im, &kps, &descs);
         return kps.size();
       }},
      {"rrslam1", "rrslam OrbExtractor, 1 thread",
       [&](const cv::Mat& im) {
         ours1.Extract(im, &kps, &descs);
         return kps.size();
       }},
      {"cv", "cv::ORB::detectAndCompute (OpenCV threads = " + std::to_string(cv_threads) + ")",
       [&](const cv::Mat& im) {
         cv_orb->detectAndCompute(im, cv::noArray(), cv_kps, cv_descs);
         return cv_kps.size();
       }},
      {"cv1", "cv::ORB::detectAndCompute (OpenCV threads = 1)",
       [&](const cv::Mat& im) {
         cv::setNumThreads(1);
         cv_orb->detectAndCompute(im, cv::noArray(), cv_kps, cv_descs);
         cv::setNumThreads(cv_threads);
         return cv_kps.size();
       }},
  };
  if (!options.variants.empty()) {
    // Profiling aid: time only the named variants (the report then has no ratios).
    std::vector<Variant> kept;
    for (Variant& v : variants) {
      if (std::find(options.variants.begin(), options.variants.end(), v.id) !=
          options.variants.end()) {
        kept.push_back(std::move(v));
      }
    }
    variants = std::move(kept);
    if (variants.empty()) throw rrslam::UsageError("--variants names no known variant");
  }
  for (int w = 0; w < options.warmup; ++w) {
    for (Variant& v : variants) v.run(images[w % n]);
  }
  {
    rrslam::ProgressBar progress("bench", n, "frame");
    for (size_t i = 0; i < n; ++i) {
      for (size_t k = 0; k < variants.size(); ++k) {
        Variant& v = variants[(i + k) % variants.size()];
        const auto start = std::chrono::steady_clock::now();
        const size_t count = v.run(images[i]);
        const auto stop = std::chrono::steady_clock::now();
        v.ms.push_back(std::chrono::duration<double, std::milli>(stop - start).count());
        v.counts.push_back(count);
      }
      progress.Advance();
    }
  }

  std::printf("sequence: %s (%zu frames, %dx%d, preloaded)\n", options.sequence.c_str(), n,
              images[0].cols, images[0].rows);
  std::printf("settings: nFeatures %d, scaleFactor %g, nLevels %d, iniThFAST %d, minThFAST %d\n",
              orb.n_features, orb.scale_factor, orb.n_levels, orb.ini_th_fast, orb.min_th_fast);
  std::printf("%-52s %9s %9s %9s %9s %9s\n", "variant", "median", "mean", "p10", "p90", "features");
  for (const Variant& v : variants) {
    const double mean = std::accumulate(v.ms.begin(), v.ms.end(), 0.0) / v.ms.size();
    const double features =
        std::accumulate(v.counts.begin(), v.counts.end(), 0.0) / v.counts.size();
    std::printf("%-52s %6.2f ms %6.2f ms %6.2f ms %6.2f ms %9.1f\n", v.name.c_str(),
                Percentile(v.ms, 0.5), mean, Percentile(v.ms, 0.1), Percentile(v.ms, 0.9),
                features);
  }
  if (variants.size() < 4) return;
  const double ours = Percentile(variants[0].ms, 0.5);
  const double ours_single = Percentile(variants[1].ms, 0.5);
  const double reference = Percentile(variants[2].ms, 0.5);
  const double reference_single = Percentile(variants[3].ms, 0.5);
  std::printf("ratio rrslam(2 threads) / cv::ORB(%d threads), medians: %.2f (goal <= 1.2): %s\n",
              cv_threads, ours / reference, ours / reference <= 1.2 ? "met" : "NOT met");
  std::printf("ratio rrslam(1 thread) / cv::ORB(1 thread), medians: %.2f\n",
              ours_single / reference_single);
  std::printf("rrslam(2 threads) median %.2f ms per frame (goal <= 12 ms): %s\n", ours,
              ours <= 12.0 ? "met" : "NOT met");
}

}  // namespace

int main(int argc, char** argv) {
  BenchOptions options;
  return rrslam::RunTool(
      argc, argv,
      {"bench-extract", "Times ORB extraction per frame: rrslam's extractor beside cv::ORB."},
      [&](CLI::App& app) {
        app.add_option("--sequence", options.sequence, "TUM-layout sequence folder")->required();
        app.add_option("--settings", options.settings, "Settings YAML (ORBextractor.*)")
            ->required();
        app.add_option("--frames", options.frames, "Frames to time (first N of the sequence)")
            ->capture_default_str();
        app.add_option("--warmup", options.warmup, "Untimed warm-up extractions per variant")
            ->capture_default_str();
        app.add_option("--variants", options.variants,
                       "Time only these variants (rrslam2 rrslam1 cv cv1), e.g. for perf");
      },
      [&] { RunBench(options); });
}
