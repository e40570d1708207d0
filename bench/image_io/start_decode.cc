// bench_image_io_start_<decoder>: a process that decodes one image file and
// exits, the subject of bench_image_io's start-up measurement. Built three
// times (bench/image_io/CMakeLists.txt), with BENCH_IMAGE_IO_DECODER_RRSLAM
// (common/image_io.h's ReadImage), _OIIO (OpenImageIO) or _IMGCODECS
// (cv::imread); all three link rrslam_common, as every stage does.
//
//   bench_image_io_start_<decoder> IMAGE
// Prints one line to stdout:
//   <main_ns> <cpu_at_main_ns> <decoded_ns> <objects_at_main> <objects_after>
//   <cols> <rows> <type> <sum>
// CLOCK_MONOTONIC at main's entry (the driver's clock too), the CPU time the
// process had used by then (exec, dynamic loading, constructors),
// CLOCK_MONOTONIC after the decode, the objects mapped into the process at
// main's entry and after the decode (dl_iterate_phdr: the executable, the
// vDSO, ld.so and every shared library, dlopen'ed ones too), and the image's
// size, OpenCV type and pixel sum (so that the decode cannot be left out).
// Exit 0; 1 when decoding fails.
#include <link.h>
#include <time.h>

#include <cstdio>
#include <exception>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>

#if defined(BENCH_IMAGE_IO_DECODER_OIIO)
#include "bench/image_io/oiio_decode.h"
#elif defined(BENCH_IMAGE_IO_DECODER_IMGCODECS)
#include <opencv2/imgcodecs.hpp>
#elif defined(BENCH_IMAGE_IO_DECODER_RRSLAM)
#include "common/image_io.h"
#else
#error "define BENCH_IMAGE_IO_DECODER_RRSLAM, _OIIO or _IMGCODECS"
#endif

namespace {

long long ClockNs(clockid_t clock) {
  timespec t;
  clock_gettime(clock, &t);
  return t.tv_sec * 1000000000LL + t.tv_nsec;
}

int LoadedObjects() {
  int n = 0;
  dl_iterate_phdr([](dl_phdr_info*, size_t, void* count) { return ++*static_cast<int*>(count), 0; },
                  &n);
  return n;
}

cv::Mat Decode(const char* path) {
#if defined(BENCH_IMAGE_IO_DECODER_OIIO)
  return rrslam::bench::ReadImageOiio(path);
#elif defined(BENCH_IMAGE_IO_DECODER_IMGCODECS)
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw std::runtime_error(std::string(path) + ": cv::imread failed");
  return image;
#else
  return rrslam::ReadImage(path);
#endif
}

}  // namespace

int main(int argc, char** argv) {
  const long long main_ns = ClockNs(CLOCK_MONOTONIC);
  const long long cpu_at_main_ns = ClockNs(CLOCK_PROCESS_CPUTIME_ID);
  const int objects_at_main = LoadedObjects();
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s IMAGE\n", argv[0]);
    return 64;
  }
  try {
    const cv::Mat image = Decode(argv[1]);
    const long long decoded_ns = ClockNs(CLOCK_MONOTONIC);
    const cv::Scalar sum = cv::sum(image);
    std::printf("%lld %lld %lld %d %d %d %d %d %.17g\n", main_ns, cpu_at_main_ns, decoded_ns,
                objects_at_main, LoadedObjects(), image.cols, image.rows, image.type(),
                sum[0] + sum[1] + sum[2] + sum[3]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
