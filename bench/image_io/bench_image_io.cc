// bench_image_io: rrslam's image decoding (common/image_io.h, libpng and
// libjpeg-turbo called directly) against OpenImageIO and OpenCV's imgcodecs,
// for the issue "replace common/image_io.cc with OpenImageIO (or OpenCV)
// unless a benchmark shows it slower" (`make bench-image-io`).
//
//   bench_image_io --images NAME:LIST [--images NAME:LIST]... [--decodes N]
//                  --start-dir DIR --start-image FILE [--starts N]
//                  --machine TEXT --command TEXT --out PREFIX
// Decode, in this process: for each image set (a TUM `timestamp path` list
// such as rgb.txt; lists given under one NAME are merged), N files evenly
// spaced through it (all of them, taken in turn, when there are fewer), each
// read from its file (in the page cache after the warm-up) by
//   (a) rrslam::ReadImage(path) (kUnchanged),
//   (b) OpenImageIO's ImageInput into the same cv::Mat, BGR (oiio_decode.h):
//       read_native_scanlines, the candidate; and read_image, for comparison,
//   (c) cv::imread(path, cv::IMREAD_UNCHANGED).
// A warm-up pass decodes every file with each decoder and compares (b) and (c)
// with (a): type, size, largest absolute difference of a channel value, and
// how many images and values differ. Then N timed decodes per decoder: in 4
// rounds, each decoder's share of a round in one block, the order of the
// blocks rotating from round to round so that load from other processes on
// the machine falls on all decoders alike: median and p95 ms per image.
// Blocks, not image by image: how long a decode takes depends on whether the
// ~1 MB it allocates comes back from the heap or as fresh pages (page faults,
// dear on a VM), i.e. on glibc malloc's dynamic mmap and trim thresholds,
// which the allocations of the decoder run before move (OpenImageIO decodes
// made the cv::imread decodes between them 4x slower on JPEG). The timing runs
// twice: with glibc's defaults (what a stage gets out of the box), then with
// both thresholds fixed high (mallopt), so that no decoder pays for page
// faults; the verdict uses the second, the fairer to the candidates.
//
// Start-up: the probes bench_image_io_start_{rrslam,oiio,imgcodecs}
// (start_decode.cc; all link rrslam_common, as every stage does, and one
// decoder; the linker's --as-needed keeps only the libraries each calls)
// each decode FILE in a fresh process. After one warm-up run each,
// they are spawned (posix_spawn) N times each, interleaved, with LD_BIND_NOW
// unset and set: wall time from the spawn to the child reaped, split at the
// child's main() and the end of its decode (CLOCK_MONOTONIC on both sides);
// CPU time used before main() (exec, dynamic loading, constructors) and in
// all (user + system, wait4); ldd entries; objects mapped. One more run each
// with LD_DEBUG=statistics gives the symbol relocations ld.so resolved. (Its
// cycle counts are not used: on the VM this was written on they came to a
// tenth of the CPU time callgrind attributes to the same relocation.)
//
// Verdicts: a candidate decodes slower when its median is above 1.05 x
// ReadImage's on an image set; it starts slower when its probe's median wall
// time is above the ReadImage probe's p95. The rule (replace unless
// slower), applied to OpenImageIO read with read_native_scanlines, then gives
// the overall verdict.
// Writes PREFIX.txt and PREFIX.json; exit 0 when every decode and run worked.
#include <fcntl.h>
#include <malloc.h>
#include <png.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

// clang-format off
#include <cstdio>  // jpeglib.h needs FILE and size_t first.
#include <jpeglib.h>
// clang-format on

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "bench/common/bench_report.h"
#include "bench/image_io/oiio_decode.h"
#include "common/atomic_file.h"
#include "common/clock.h"
#include "common/dataset.h"
#include "common/image_io.h"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using nlohmann::ordered_json;
using rrslam::bench::Median;
using rrslam::bench::Percentile;
using rrslam::bench::Report;

std::string Fixed(double value, int digits) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << value;
  return out.str();
}

long long MonotonicNs() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec * 1000000000LL + t.tv_nsec;
}

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

std::string TypeText(const cv::Mat& m) {
  return std::to_string(m.cols) + "x" + std::to_string(m.rows) + " " +
         (m.depth() == CV_16U ? "16" : "8") + "-bit x" + std::to_string(m.channels());
}

// ---- Decode -------------------------------------------------------------------

struct Decoder {
  std::string name;
  std::function<cv::Mat(const fs::path&)> decode;
};

struct ImageSet {
  std::string name;
  std::vector<fs::path> lists;
  std::vector<fs::path> files;  // All listed files, in list order.
};

// Agreement of a decoder's pixels with ReadImage's over a set.
struct Agreement {
  int other_type_or_size = 0;   // Images of another type or size.
  int differing_images = 0;     // Images with any channel value different.
  double max_abs = 0;           // Largest |difference| of a channel value.
  double differing_values = 0;  // Channel values that differ, over all images.
  double values = 0;            // Channel values compared.
};

void Compare(const cv::Mat& reference, const cv::Mat& other, Agreement* a) {
  if (reference.type() != other.type() || reference.size() != other.size()) {
    ++a->other_type_or_size;
    return;
  }
  cv::Mat difference;
  cv::absdiff(reference, other, difference);
  difference = difference.reshape(1);
  double max_abs = 0;
  cv::minMaxLoc(difference, nullptr, &max_abs);
  const int differing = cv::countNonZero(difference);
  a->max_abs = std::max(a->max_abs, max_abs);
  a->differing_images += differing > 0;
  a->differing_values += differing;
  a->values += static_cast<double>(difference.total());
}

// Warm-up: every file once with each decoder (page cache, lazy
// initialization in the libraries), and the pixel comparison. Per decoder;
// [0] is ReadImage itself.
std::vector<Agreement> WarmUpAndCompare(const ImageSet& set, const std::vector<Decoder>& decoders) {
  std::vector<Agreement> agreement(decoders.size());
  for (const fs::path& file : set.files) {
    const cv::Mat reference = decoders[0].decode(file);
    for (size_t d = 1; d < decoders.size(); ++d) {
      Compare(reference, decoders[d].decode(file), &agreement[d]);
    }
  }
  return agreement;
}

// `decodes` timed decodes per decoder (ms, per decoder), in rounds of blocks.
std::vector<std::vector<double>> TimeDecoders(const ImageSet& set,
                                              const std::vector<Decoder>& decoders, int decodes) {
  constexpr int kRounds = 4;
  const int per_round = (decodes + kRounds - 1) / kRounds;
  std::vector<std::vector<double>> ms(decoders.size());
  for (int round = 0; round < kRounds; ++round) {
    for (size_t k = 0; k < decoders.size(); ++k) {
      const size_t d = (static_cast<size_t>(round) + k) % decoders.size();
      for (int i = round * per_round; i < std::min(decodes, (round + 1) * per_round); ++i) {
        const fs::path& file = set.files[static_cast<size_t>(i) % set.files.size()];
        const auto start = rrslam::SteadyClock::now();
        const cv::Mat image = decoders[d].decode(file);
        ms[d].push_back(rrslam::MillisecondsSince(start));
        if (image.empty()) throw std::runtime_error(file.string() + ": empty image");
      }
    }
  }
  return ms;
}

// ---- Start-up -------------------------------------------------------------------

struct Probe {
  std::string decoder;  // As in Decoder::name.
  fs::path exe;
};

struct StartSample {
  double wall_ms = 0;         // Spawn to child reaped.
  double to_main_ms = 0;      // Spawn to the child's main().
  double cpu_at_main_ms = 0;  // CPU time the child had used by main().
  double decode_ms = 0;       // The child's decode (its first in the process).
  double after_ms = 0;        // End of the decode to reaped: exit, destructors, unmapping.
  double cpu_ms = 0;          // User + system time of the child.
  int objects_at_main = 0, objects_after = 0;
};

// Runs `exe image` with the environment of this process minus LD_BIND_NOW
// and LD_DEBUG, plus `extra_env`; the child's stderr goes to `stderr_file`
// when given. Throws when it cannot be run or fails.
StartSample Spawn(const fs::path& exe, const fs::path& image,
                  const std::vector<std::string>& extra_env, const fs::path& stderr_file = {}) {
  std::vector<std::string> env;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string_view entry(*e);
    if (entry.starts_with("LD_BIND_NOW=") || entry.starts_with("LD_DEBUG=")) continue;
    env.emplace_back(entry);
  }
  env.insert(env.end(), extra_env.begin(), extra_env.end());
  std::vector<char*> envp;
  for (std::string& e : env) envp.push_back(e.data());
  envp.push_back(nullptr);
  std::string exe_text = exe.string(), image_text = image.string();
  char* argv[] = {exe_text.data(), image_text.data(), nullptr};

  int pipe_fds[2];
  if (pipe2(pipe_fds, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
  if (!stderr_file.empty()) {
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, stderr_file.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
  }
  pid_t pid = 0;
  const long long spawn_ns = MonotonicNs();
  const int spawned = posix_spawn(&pid, exe_text.c_str(), &actions, nullptr, argv, envp.data());
  posix_spawn_file_actions_destroy(&actions);
  close(pipe_fds[1]);
  std::string out;
  char buffer[512];
  for (ssize_t n; (n = read(pipe_fds[0], buffer, sizeof(buffer))) != 0;) {
    if (n > 0) out.append(buffer, static_cast<size_t>(n));
    if (n < 0 && errno != EINTR) break;
  }
  close(pipe_fds[0]);
  if (spawned != 0) throw std::runtime_error(exe_text + ": " + std::strerror(spawned));
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  const long long reaped_ns = MonotonicNs();
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error(exe_text + " " + image_text + " failed (status " +
                             std::to_string(status) + ")");
  }
  long long main_ns = 0, cpu_at_main_ns = 0, decoded_ns = 0;
  StartSample s;
  std::istringstream line(out);
  line >> main_ns >> cpu_at_main_ns >> decoded_ns >> s.objects_at_main >> s.objects_after;
  if (!line) throw std::runtime_error(exe_text + ": unexpected output '" + out + "'");
  s.wall_ms = (reaped_ns - spawn_ns) / 1e6;
  s.to_main_ms = (main_ns - spawn_ns) / 1e6;
  s.cpu_at_main_ms = cpu_at_main_ns / 1e6;
  s.decode_ms = (decoded_ns - main_ns) / 1e6;
  s.after_ms = (reaped_ns - decoded_ns) / 1e6;
  auto ms = [](const timeval& t) { return t.tv_sec * 1e3 + t.tv_usec / 1e3; };
  s.cpu_ms = ms(usage.ru_utime) + ms(usage.ru_stime);
  return s;
}

// Lines of `ldd exe` (shared libraries, ld.so and the vDSO).
int LddEntries(const fs::path& exe) {
  FILE* pipe = popen(("ldd " + rrslam::bench::Quote(exe)).c_str(), "r");
  if (pipe == nullptr) return -1;
  int lines = 0;
  for (int c; (c = std::fgetc(pipe)) != EOF;) lines += c == '\n';
  return pclose(pipe) == 0 ? lines : -1;
}

// ld.so's relocation counts at start-up (LD_DEBUG=statistics, first block).
struct LoaderStatistics {
  double relocations = 0;           // Symbol lookups (each searches the global scope).
  double relative_relocations = 0;  // Base address added, no lookup.
};

LoaderStatistics ParseLoaderStatistics(const std::string& text) {
  auto value = [&](const std::string& key) {
    const size_t at = text.find(key + ": ");
    return at == std::string::npos ? 0.0 : std::atof(text.c_str() + at + key.size() + 2);
  };
  return {value("number of relocations"), value("number of relative relocations")};
}

std::string VersionText() {
  const png_uint_32 png = png_access_version_number();
  std::string text = "libpng " + std::to_string(png / 10000) + "." +
                     std::to_string(png / 100 % 100) + "." + std::to_string(png % 100);
#if defined(LIBJPEG_TURBO_VERSION_NUMBER)
  const int jpeg = LIBJPEG_TURBO_VERSION_NUMBER;  // 1000000 major + 1000 minor + patch.
  text += ", libjpeg-turbo " + std::to_string(jpeg / 1000000) + "." +
          std::to_string(jpeg / 1000 % 1000) + "." + std::to_string(jpeg % 1000);
#endif
  text += " (headers), OpenImageIO " + rrslam::bench::OiioVersion() + ", OpenCV " +
          cv::getVersionString();
  return text;
}

// ---- The steps of main --------------------------------------------------------

struct Options {
  std::vector<std::string> image_specs;  // NAME:LIST.
  int decodes = 200, starts = 20;
  fs::path start_dir, start_image;
  std::string machine, command, out_prefix;
};

// What the decode measurements found on one image set.
struct SetResult {
  size_t listed = 0;                 // Files its lists name (ImageSet::files: those picked).
  bool usable = false;               // Listed, warmed up and timed without an error.
  std::vector<Agreement> agreement;  // Per decoder; [0] is ReadImage itself.
  // Per decoder, the timed decodes (ms): glibc malloc's defaults, its thresholds fixed.
  std::vector<std::vector<double>> ms_default, ms_fixed;
};

// What the steps share.
struct Bench {
  Options options;
  std::string driver_command;  // This process's argv, quoted.
  std::string load_at_start;
  std::vector<Decoder> decoders;
  std::vector<ImageSet> sets;
  std::vector<SetResult> results;  // Per set.
  Report report;
  bool failed = false;
  std::vector<std::string> verdicts;
  std::vector<std::string> slower_oiio;  // Criteria on which OpenImageIO is slower.
  ordered_json sets_json = ordered_json::array();
  ordered_json start_json = ordered_json::array();
};

void AddOptions(CLI::App& app, Options* o) {
  app.add_option("--images", o->image_specs,
                 "NAME:LIST, a set of images (repeat; lists of one NAME "
                 "are merged)")
      ->required();
  app.add_option("--decodes", o->decodes, "Timed decodes per decoder and set")
      ->capture_default_str();
  app.add_option("--start-dir", o->start_dir, "Folder of the bench_image_io_start_* probes")
      ->required();
  app.add_option("--start-image", o->start_image, "Image the probes decode")->required();
  app.add_option("--starts", o->starts, "Timed runs per probe and setting")->capture_default_str();
  app.add_option("--machine", o->machine, "Machine description line");
  app.add_option("--command", o->command, "Command that reproduces this run (recorded)");
  app.add_option("--out", o->out_prefix, "Result files prefix (writes .txt and .json)")->required();
}

std::string DriverCommand(int argc, char** argv) {
  std::string driver_command;
  for (int i = 0; i < argc; ++i) {
    driver_command += (i ? " " : "") + rrslam::ShellQuote(argv[i]);
  }
  return driver_command;
}

std::vector<Decoder> MakeDecoders() {
  return {
      {"ReadImage", [](const fs::path& p) { return rrslam::ReadImage(p); }},
      {"OpenImageIO", [](const fs::path& p) { return rrslam::bench::ReadImageOiio(p); }},
      {"OIIO read_image",
       [](const fs::path& p) {
         return rrslam::bench::ReadImageOiio(p, rrslam::bench::OiioRead::kReadImage);
       }},
      {"cv::imread",
       [](const fs::path& p) {
         cv::Mat image = cv::imread(p.string(), cv::IMREAD_UNCHANGED);
         if (image.empty()) throw std::runtime_error(p.string() + ": cv::imread failed");
         return image;
       }},
  };
}

// Image sets, in the order first named. False (after a message) on a bad spec.
bool ParseImageSets(const std::vector<std::string>& image_specs, std::vector<ImageSet>* sets) {
  for (const std::string& spec : image_specs) {
    const size_t colon = spec.find(':');
    if (colon == std::string::npos || colon == 0) {
      std::cerr << "bench_image_io: --images " << spec << ": expected NAME:LIST\n";
      return false;
    }
    const std::string name = spec.substr(0, colon);
    auto set =
        std::find_if(sets->begin(), sets->end(), [&](const ImageSet& s) { return s.name == name; });
    if (set == sets->end()) set = sets->insert(sets->end(), ImageSet{name, {}, {}});
    set->lists.emplace_back(spec.substr(colon + 1));
  }
  return true;
}

// Reads the set's lists into set->files, then keeps `decodes` of them evenly
// spaced when there are more. Returns how many were listed.
size_t ListFiles(int decodes, ImageSet* set) {
  for (const fs::path& list : set->lists) {
    for (const auto& [stamp, file] : rrslam::ReadTimestampList(list)) {
      set->files.push_back(list.parent_path() / file);
    }
  }
  const size_t listed = set->files.size();
  if (listed > static_cast<size_t>(decodes)) {
    std::vector<fs::path> picked;
    for (size_t i = 0; i < static_cast<size_t>(decodes); ++i) {
      picked.push_back(set->files[i * listed / static_cast<size_t>(decodes)]);
    }
    set->files = std::move(picked);
  }
  return listed;
}

// Files, warm-up and pixel comparison.
void ListAndWarmUp(Bench* b) {
  for (size_t q = 0; q < b->sets.size(); ++q) {
    ImageSet& set = b->sets[q];
    SetResult& result = b->results[q];
    const std::string s = "decode: " + set.name;
    try {
      result.listed = ListFiles(b->options.decodes, &set);
      if (set.files.empty()) throw std::runtime_error("no images listed");
      std::cerr << "bench_image_io: warm-up and pixel comparison, " << set.name << " ("
                << set.files.size() << " files)" << std::endl;
      result.agreement = WarmUpAndCompare(set, b->decoders);
      result.usable = true;
    } catch (const std::exception& e) {
      b->report.Note(s, std::string("failed: ") + e.what());
      std::cerr << "bench_image_io: " << s << ": " << e.what() << "\n";
      b->failed = true;
    }
  }
}

// Timing: glibc malloc's defaults, then its thresholds fixed.
void TimeDecodes(Bench* b) {
  for (int fixed = 0; fixed < 2; ++fixed) {
    if (fixed) {
      // The largest mmap threshold glibc accepts (32 MiB on 64-bit), and no
      // trimming of the heap top below 1 GiB.
      mallopt(M_MMAP_THRESHOLD, 32 << 20);
      mallopt(M_TRIM_THRESHOLD, 1 << 30);
    }
    for (size_t q = 0; q < b->sets.size(); ++q) {
      SetResult& result = b->results[q];
      if (!result.usable) continue;
      std::cerr << "bench_image_io: timing " << b->sets[q].name << ", glibc malloc "
                << (fixed ? "thresholds fixed" : "defaults") << std::endl;
      try {
        (fixed ? result.ms_fixed : result.ms_default) =
            TimeDecoders(b->sets[q], b->decoders, b->options.decodes);
      } catch (const std::exception& e) {
        b->report.Note("decode: " + b->sets[q].name, std::string("failed: ") + e.what());
        std::cerr << "bench_image_io: " << b->sets[q].name << ": " << e.what() << "\n";
        b->failed = true;
        result.usable = false;
      }
    }
  }
}

// Decoder d's times on a set (section s) against ReadImage's median
// `reference`; its JSON entry.
ordered_json ReportDecodeTimes(const std::string& s, size_t d, double reference, const SetResult& r,
                               Bench* b) {
  const std::string& name = b->decoders[d].name;
  const double median = Median(r.ms_fixed[d]);
  const double p95 = Percentile(r.ms_fixed[d], 0.95);
  const double median_default = Median(r.ms_default[d]);
  if (d == 0) {
    b->report.Add(s, {name + " per image (median)", median, "ms", "-", true});
  } else {
    b->report.Add(s, {name + " per image (median)", median, "ms",
                      "<= " + Fixed(1.05 * reference, 2) + " ms", median <= 1.05 * reference});
  }
  b->report.Add(s, {"  p95", p95, "ms", "-", true});
  b->report.Add(s, {"  glibc malloc defaults: median", median_default, "ms", "-", true});
  b->report.Add(
      s, {"  glibc malloc defaults: p95", Percentile(r.ms_default[d], 0.95), "ms", "-", true});
  return {{"decoder", name},
          {"malloc_thresholds_fixed", {{"median_ms", median}, {"p95_ms", p95}}},
          {"malloc_defaults",
           {{"median_ms", median_default}, {"p95_ms", Percentile(r.ms_default[d], 0.95)}}}};
}

// A candidate's pixels against ReadImage's on a set of `files` files; their JSON.
ordered_json ReportPixels(const std::string& s, const Agreement& a, size_t files, bool png,
                          Report* report) {
  const bool must_match = png;  // Lossless: every decoder must give the same values.
  report->Add(s, {"  images of another type or size", double(a.other_type_or_size),
                  "of " + std::to_string(files), "0", a.other_type_or_size == 0});
  report->Add(s, {"  max |difference| from ReadImage", a.max_abs, "", must_match ? "0" : "- (IDCT)",
                  !must_match || a.max_abs == 0});
  report->Add(s, {"  images differing from ReadImage", double(a.differing_images),
                  "of " + std::to_string(files), must_match ? "0" : "-",
                  !must_match || a.differing_images == 0});
  const double share = a.values > 0 ? 100 * a.differing_values / a.values : 0;
  report->Add(s, {"  channel values differing", share, "%", "-", true});
  return {{"other_type_or_size", a.other_type_or_size},
          {"max_abs_difference", a.max_abs},
          {"differing_images", a.differing_images},
          {"differing_values_percent", share}};
}

// Candidate d's decode verdict on a set.
void AddDecodeVerdict(const ImageSet& set, const SetResult& r, size_t d, Bench* b) {
  const double reference = Median(r.ms_fixed[0]);
  const double reference_default = Median(r.ms_default[0]);
  const double median = Median(r.ms_fixed[d]);
  const double median_default = Median(r.ms_default[d]);
  const Agreement& a = r.agreement[d];
  const bool slower = median > 1.05 * reference;
  b->verdicts.push_back(
      b->decoders[d].name + " decode is " + Fixed(median, 2) + " ms vs " + Fixed(reference, 2) +
      " ms (ReadImage) per " + set.name + " image, " + Fixed(median / reference, 2) +
      " x (glibc malloc defaults: " + Fixed(median_default, 2) + " vs " +
      Fixed(reference_default, 2) + " ms): " + (slower ? "slower" : "not slower") + "; pixels " +
      (a.other_type_or_size == 0 && a.max_abs == 0 ? "identical"
                                                   : "max |difference| " + Fixed(a.max_abs, 0)));
  if (slower && d == 1) b->slower_oiio.push_back("decode of " + set.name);
}

// Figures, JSON and verdicts of the decode measurements on one set.
void ReportSet(const ImageSet& set, const SetResult& r, Bench* b) {
  const std::string s = "decode: " + set.name;
  std::string ext = set.files.front().extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  const bool png = ext == ".png";
  const std::string layout = TypeText(rrslam::ReadImage(set.files.front()));
  std::string lists;
  for (const fs::path& l : set.lists) lists += (lists.empty() ? "" : ", ") + l.string();
  b->report.Note(s, std::string(png ? "PNG" : "JPEG") + " " + layout + "; " +
                        std::to_string(set.files.size()) + " files evenly spaced of " +
                        std::to_string(r.listed) + " listed in " + lists + "; " +
                        std::to_string(b->options.decodes) +
                        " timed decodes per decoder and allocator mode");
  const double reference = Median(r.ms_fixed[0]);
  ordered_json set_json = {{"name", set.name},   {"format", png ? "PNG" : "JPEG"},
                           {"layout", layout},   {"files", set.files.size()},
                           {"listed", r.listed}, {"decoders", ordered_json::array()}};
  for (size_t d = 0; d < b->decoders.size(); ++d) {
    ordered_json decoder_json = ReportDecodeTimes(s, d, reference, r, b);
    if (d > 0) {
      decoder_json["pixels"] = ReportPixels(s, r.agreement[d], set.files.size(), png, &b->report);
      AddDecodeVerdict(set, r, d, b);
    }
    set_json["decoders"].push_back(decoder_json);
  }
  b->sets_json.push_back(set_json);
}

// The start-up runs of the probes.
struct StartUp {
  std::vector<Probe> probes;
  // Per variant v: probe v / 2, LD_BIND_NOW set when v is odd.
  std::vector<std::vector<StartSample>> samples;  // Empty when the runs failed.
  std::vector<LoaderStatistics> loader;
};

std::vector<std::string> VariantEnv(size_t v) {
  return v % 2 ? std::vector<std::string>{"LD_BIND_NOW=1"} : std::vector<std::string>{};
}

StartUp MeasureStartUp(Bench* b) {
  const fs::path& start_dir = b->options.start_dir;
  const fs::path& start_image = b->options.start_image;
  StartUp st;
  st.probes = {
      {"ReadImage", start_dir / "bench_image_io_start_rrslam"},
      {"OpenImageIO", start_dir / "bench_image_io_start_oiio"},
      {"cv::imread", start_dir / "bench_image_io_start_imgcodecs"},
  };
  const size_t variants = 2 * st.probes.size();
  st.samples.resize(variants);
  st.loader.resize(variants);
  try {
    std::cerr << "bench_image_io: start-up, " << b->options.starts << " runs of " << variants
              << " variants" << std::endl;
    for (size_t v = 0; v < variants; ++v) {
      Spawn(st.probes[v / 2].exe, start_image, VariantEnv(v));  // Warm-up.
    }
    for (int r = 0; r < b->options.starts; ++r) {
      for (size_t k = 0; k < variants; ++k) {
        const size_t v = (static_cast<size_t>(r) + k) % variants;
        st.samples[v].push_back(Spawn(st.probes[v / 2].exe, start_image, VariantEnv(v)));
      }
    }
    // The loader's relocation counts (the same in every run).
    const fs::path log =
        fs::temp_directory_path() / ("bench_image_io_ld_" + std::to_string(getpid()) + ".txt");
    for (size_t v = 0; v < variants; ++v) {
      std::vector<std::string> env = VariantEnv(v);
      env.push_back("LD_DEBUG=statistics");
      Spawn(st.probes[v / 2].exe, start_image, env, log);
      st.loader[v] = ParseLoaderStatistics(rrslam::ReadFileToString(log));
    }
    fs::remove(log);
  } catch (const std::exception& e) {
    b->report.Note("start-up", std::string("failed: ") + e.what());
    std::cerr << "bench_image_io: start-up: " << e.what() << "\n";
    b->failed = true;
    st.samples.assign(variants, {});
  }
  return st;
}

std::vector<double> Field(const std::vector<StartSample>& runs, double StartSample::*f) {
  std::vector<double> values;
  for (const StartSample& s : runs) values.push_back(s.*f);
  return values;
}

// The ReadImage probe's figures, which the candidates' are compared with.
struct StartBaseline {
  double wall = 0, wall_p95 = 0, cpu = 0;  // ms.
};

// Probe p's timings and mapped objects, in section s.
void ReportProbeFigures(const std::string& s, size_t p, const StartUp& st,
                        const StartBaseline& base, int ldd, Bench* b) {
  const std::vector<StartSample>& lazy = st.samples[2 * p];
  const std::vector<StartSample>& now = st.samples[2 * p + 1];
  const std::vector<double> wall = Field(lazy, &StartSample::wall_ms);
  const double wall_median = Median(wall);
  Report& report = b->report;
  report.Note(s, "decodes " + b->options.start_image.string() + "; " + std::to_string(lazy.size()) +
                     " runs after one warm-up, interleaved with the other probes");
  if (p == 0) {
    report.Add(s, {"wall, spawn to reaped (median)", wall_median, "ms", "-", true});
  } else {
    report.Add(s, {"wall, spawn to reaped (median)", wall_median, "ms",
                   "<= " + Fixed(base.wall_p95, 1) + " ms", wall_median <= base.wall_p95});
  }
  report.Add(s, {"  p95", Percentile(wall, 0.95), "ms", "-", true});
  report.Add(s, {"  spawn to main() (median)", Median(Field(lazy, &StartSample::to_main_ms)), "ms",
                 "-", true});
  report.Add(s, {"  CPU time used before main() (median)",
                 Median(Field(lazy, &StartSample::cpu_at_main_ms)), "ms", "-", true});
  report.Add(s, {"  first decode in the process (median)",
                 Median(Field(lazy, &StartSample::decode_ms)), "ms", "-", true});
  report.Add(s, {"  decode end to reaped (median)", Median(Field(lazy, &StartSample::after_ms)),
                 "ms", "-", true});
  report.Add(s, {"CPU time, user + system (median)", Median(Field(lazy, &StartSample::cpu_ms)),
                 "ms", "-", true});
  report.Add(s, {"ldd entries", double(ldd), "", "-", true});
  report.Add(s, {"objects mapped at main()", double(lazy.front().objects_at_main), "", "-", true});
  report.Add(
      s, {"objects mapped after the decode", double(lazy.front().objects_after), "", "-", true});
  report.Add(s, {"LD_BIND_NOW=1: wall (median)", Median(Field(now, &StartSample::wall_ms)), "ms",
                 "-", true});
  report.Add(s, {"LD_BIND_NOW=1: CPU time (median)", Median(Field(now, &StartSample::cpu_ms)), "ms",
                 "-", true});
}

// Probe p's runs as JSON, and its relocation counts in section s.
ordered_json ReportProbeRuns(const std::string& s, size_t p, const StartUp& st, int ldd,
                             Report* report) {
  const std::vector<StartSample>& lazy = st.samples[2 * p];
  ordered_json probe_json = {{"probe", st.probes[p].exe.filename().string()},
                             {"decoder", st.probes[p].decoder},
                             {"ldd_entries", ldd},
                             {"objects_at_main", lazy.front().objects_at_main},
                             {"objects_after_decode", lazy.front().objects_after}};
  for (int bind_now = 0; bind_now < 2; ++bind_now) {
    const std::vector<StartSample>& runs = st.samples[2 * p + bind_now];
    const LoaderStatistics& l = st.loader[2 * p + bind_now];
    ordered_json runs_json = {{"wall_ms", Field(runs, &StartSample::wall_ms)},
                              {"to_main_ms", Field(runs, &StartSample::to_main_ms)},
                              {"cpu_at_main_ms", Field(runs, &StartSample::cpu_at_main_ms)},
                              {"decode_ms", Field(runs, &StartSample::decode_ms)},
                              {"after_decode_ms", Field(runs, &StartSample::after_ms)},
                              {"cpu_ms", Field(runs, &StartSample::cpu_ms)},
                              {"symbol_relocations", l.relocations},
                              {"relative_relocations", l.relative_relocations}};
    probe_json[bind_now ? "ld_bind_now" : "lazy"] = runs_json;
    report->Add(s, {bind_now ? "  with LD_BIND_NOW=1" : "symbol relocations at start (ld.so)",
                    l.relocations, "", "-", true});
  }
  return probe_json;
}

// Candidate probe p's start-up verdicts.
void AddStartVerdicts(size_t p, const StartUp& st, const StartBaseline& base, int ldd, Bench* b) {
  const double wall_median = Median(Field(st.samples[2 * p], &StartSample::wall_ms));
  const double cpu = Median(Field(st.samples[2 * p], &StartSample::cpu_ms));
  const double now_wall = Median(Field(st.samples[2 * p + 1], &StartSample::wall_ms));
  const std::string& decoder = st.probes[p].decoder;
  const bool slower = wall_median > base.wall_p95;
  const int base_ldd = LddEntries(st.probes[0].exe);
  b->verdicts.push_back(decoder + " start-up " + (wall_median >= base.wall ? "+" : "") +
                        Fixed(wall_median - base.wall, 1) + " ms wall (" + Fixed(wall_median, 1) +
                        " vs " + Fixed(base.wall, 1) + " ms, median), " +
                        (cpu >= base.cpu ? "+" : "") + Fixed(cpu - base.cpu, 1) + " ms CPU, " +
                        std::to_string(ldd) + " vs " + std::to_string(base_ldd) +
                        " ldd entries: " + (slower ? "slower" : "not slower"));
  b->verdicts.push_back(decoder + " start-up with LD_BIND_NOW=1: " + Fixed(now_wall, 1) +
                        " ms vs " + Fixed(wall_median, 1) + " ms lazy binding (median wall)");
  if (slower && p == 1) b->slower_oiio.push_back("start-up");
}

// Figures, JSON and verdicts of the start-up runs (none when they failed).
void ReportStartUp(const StartUp& st, Bench* b) {
  if (st.samples[0].empty()) return;
  const std::vector<double> base_walls = Field(st.samples[0], &StartSample::wall_ms);
  const StartBaseline base = {Median(base_walls), Percentile(base_walls, 0.95),
                              Median(Field(st.samples[0], &StartSample::cpu_ms))};
  for (size_t p = 0; p < st.probes.size(); ++p) {
    const std::string s =
        "start-up: " + st.probes[p].exe.filename().string() + " (" + st.probes[p].decoder + ")";
    const int ldd = LddEntries(st.probes[p].exe);
    ReportProbeFigures(s, p, st, base, ldd, b);
    b->start_json.push_back(ReportProbeRuns(s, p, st, ldd, &b->report));
    if (p > 0) AddStartVerdicts(p, st, base, ldd, b);
  }
}

// The rule, applied to OpenImageIO read with read_native_scanlines.
std::string OverallVerdict(const Bench& b) {
  if (b.failed) return "none: some measurements failed";
  if (!b.slower_oiio.empty()) {
    std::string what;
    for (const std::string& w : b.slower_oiio) what += (what.empty() ? "" : ", ") + w;
    return "keep common/image_io.cc: OpenImageIO is slower (" + what + ")";
  }
  return "replace common/image_io.cc with OpenImageIO: not slower on any criterion";
}

// PREFIX.txt and PREFIX.json, and the text on stdout.
void WriteResults(const Bench& b, const std::string& overall) {
  const Options& o = b.options;
  const std::string load_at_end = LoadAverage();
  std::ostringstream text;
  text << "# bench-image-io: image decoding, rrslam's ReadImage (common/image_io.h) vs "
          "OpenImageIO vs cv::imread\n";
  text << "# command: " << (o.command.empty() ? b.driver_command : o.command) << "\n";
  text << "# driver: " << b.driver_command << "\n";
  text << "# machine: " << o.machine << "\n";
  text << "# versions: " << VersionText() << "\n";
  text << "# load average at start: " << b.load_at_start << ", at end: " << load_at_end << "\n";
  text << b.report.Text();
  text << "\nverdicts (slower: decode median > 1.05 x ReadImage's; start-up median > the "
          "ReadImage probe's p95):\n";
  for (const std::string& v : b.verdicts) text << "  " << v << "\n";
  text << "\nverdict: " << overall << "\n";
  ordered_json j;
  j["machine"] = o.machine;
  j["command"] = o.command;
  j["driver"] = b.driver_command;
  j["versions"] = VersionText();
  j["load_average"] = {{"start", b.load_at_start}, {"end", load_at_end}};
  j["figures"] = b.report.Json();
  j["decode"] = b.sets_json;
  j["start_up"] = b.start_json;
  j["verdicts"] = b.verdicts;
  j["verdict"] = overall;
  rrslam::WriteFileAtomically(o.out_prefix + ".txt", text.str());
  rrslam::WriteFileAtomically(o.out_prefix + ".json", j.dump(2) + "\n");
  std::cout << text.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Measures image decoding: rrslam's ReadImage, OpenImageIO and cv::imread.");
  Bench b;
  AddOptions(app, &b.options);
  CLI11_PARSE(app, argc, argv);
  if (b.options.decodes < 1 || b.options.starts < 1) {
    std::cerr << "bench_image_io: --decodes and --starts must be >= 1\n";
    return 64;
  }
  b.driver_command = DriverCommand(argc, argv);
  b.load_at_start = LoadAverage();
  b.decoders = MakeDecoders();
  if (!ParseImageSets(b.options.image_specs, &b.sets)) return 64;
  b.results.resize(b.sets.size());

  ListAndWarmUp(&b);
  TimeDecodes(&b);
  for (size_t q = 0; q < b.sets.size(); ++q) {
    if (b.results[q].usable) ReportSet(b.sets[q], b.results[q], &b);
  }
  ReportStartUp(MeasureStartUp(&b), &b);

  WriteResults(b, OverallVerdict(b));
  return b.failed ? 1 : 0;
}
