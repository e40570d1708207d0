#include "stages/mapstore/mapstore_tool.h"

#include <CLI/CLI.hpp>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <system_error>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/errors.h"
#include "common/formats.h"
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/path_check.h"
#include "stages/mapstore/floor.h"
#include "stages/mapstore/map_diff.h"
#include "stages/mapstore/map_file.h"

namespace rrslam {
namespace {

bool Fail(std::string* why, const std::string& text) {
  if (why != nullptr) *why = text;
  return false;
}

std::string Hex64(uint64_t value) {
  char buffer[17];
  std::snprintf(buffer, sizeof(buffer), "%016" PRIx64, value);
  return buffer;
}

// The same checks as ReadMapFile, before the file is mapped.
std::string Scalar(const nlohmann::ordered_json& v) {
  return v.is_string() ? v.get<std::string>() : DumpJson(v);
}

// "key: value" lines; objects indent their members, the section table is one
// line per section.
void AppendText(const nlohmann::ordered_json& j, const std::string& indent, std::string* text) {
  for (const auto& [key, value] : j.items()) {
    if (key == "sections" && value.is_array()) {
      *text += indent + "sections:\n";
      for (const auto& s : value) {
        char line[160];
        std::snprintf(line, sizeof(line), "%s  %-16s %12" PRIu64 " bytes  %s\n", indent.c_str(),
                      s["name"].get<std::string>().c_str(), s["size"].get<uint64_t>(),
                      s["checksum"].get<std::string>().c_str());
        *text += line;
      }
    } else if (value.is_object() && key != "metadata") {
      *text += indent + key + ":\n";
      AppendText(value, indent + "  ", text);
    } else {
      *text += indent + key + ": " + Scalar(value) + "\n";
    }
  }
}

nlohmann::ordered_json PointsJson(const std::vector<MapDiffPoint>& points) {
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const MapDiffPoint& p : points) {
    out.push_back({{"id", p.id}, {"position", {p.position[0], p.position[1], p.position[2]}}});
  }
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------
// Options

bool MapInfoOptions::Check(std::string* why) const {
  if (map.empty()) return Fail(why, "map: a map file is required");
  return true;
}

bool MapVerifyOptions::Check(std::string* why) const {
  if (map.empty()) return Fail(why, "map: a map file is required");
  return true;
}

bool MapDiffOptions::Check(std::string* why) const {
  if (a.empty()) return Fail(why, "a: the first map file is required");
  if (b.empty()) return Fail(why, "b: the second map file is required");
  if (!(radius > 0) || !std::isfinite(radius)) {
    return Fail(why, "radius = " + std::to_string(radius) + "; must be a positive distance (m)");
  }
  return CheckOutputNotInput({"--json", json_out}, {{"a", a}, {"b", b}}, why);
}

// ---------------------------------------------------------------------------
// CLI

void BindMapstoreCommands(CLI::App& app, MapstoreCommands* c) {
  app.require_subcommand(1);
  CLI::App* info = app.add_subcommand(
      "info", "Prints a map's header, sections with checksum states, counts, vocabulary, camera");
  info->add_option("map", c->info.map, "Map file (rrslam.map)")->required();
  info->add_flag("--json", c->info.json, "Print JSON");
  info->callback([c] { c->chosen = "info"; });

  CLI::App* verify =
      app.add_subcommand("verify", "Checks every checksum and relation of a map file");
  verify->add_option("map", c->verify.map, "Map file (rrslam.map)")->required();
  verify->callback([c] { c->chosen = "verify"; });

  CLI::App* diff =
      app.add_subcommand("diff", "Map points and keyframes added and removed from map A to map B");
  diff->add_option("a", c->diff.a, "Map before")->required();
  diff->add_option("b", c->diff.b, "Map after")->required();
  diff->add_option("--radius", c->diff.radius,
                   "Metres: a point with a point of the other map this close is unchanged")
      ->capture_default_str();
  diff->add_option("--json", c->diff.json_out,
                   "Write a JSON report (counts, added/removed ids and positions) here");
  diff->callback([c] { c->chosen = "diff"; });

  CLI::App* align = app.add_subcommand(
      "align-floor", "Finds the floor and stores the floor-aligned frame (z up) in the map file");
  align->add_option("map", c->align_floor.map, "Map file (rewritten atomically)")->required();
  align->add_option("--sequence", c->align_floor.sequence,
                    "Sequence folder the map was built from: search the keyframes' depth too "
                    "(default: the map points only)");
  align->add_option("--stride", c->align_floor.stride, "Depth pixels sampled every N")
      ->capture_default_str();
  align->callback([c] { c->chosen = "align-floor"; });
}

void RunMapstoreCommand(const MapstoreCommands& c) {
  if (c.chosen == "info") {
    RunMapInfo(c.info);
  } else if (c.chosen == "verify") {
    RunMapVerify(c.verify);
  } else if (c.chosen == "diff") {
    RunMapDiff(c.diff);
  } else if (c.chosen == "align-floor") {
    RunMapAlignFloor(c.align_floor);
  } else {
    throw UsageError("a command is required: info, verify, diff, align-floor or merge");
  }
}

// ---------------------------------------------------------------------------
// info

std::string RunMapInfo(const MapInfoOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const std::string name = options.map.string();
  RequireFile(options.map, "map file");
  const MappedFile file(options.map);
  const std::span<const uint8_t> bytes = file.bytes();
  // Header and table: without them nothing can be shown (throws DataError).
  const MapFileInfo header = ReadMapFileInfo(bytes, name);
  const uint32_t header_size = LoadLittleEndian<uint32_t>(bytes.data() + 12);
  const std::span<const uint8_t> payload = bytes.subspan(header_size);

  nlohmann::ordered_json j;
  j["file"] = name;
  j["format"] = std::string(kMapFormat.name) + " " + std::to_string(header.major) + "." +
                std::to_string(header.minor);
  j["size_bytes"] = header.file_size;
  std::string problem;
  bool meta_ok = false;
  nlohmann::ordered_json sections = nlohmann::ordered_json::array();
  for (const MapSectionInfo& s : header.sections) {
    const uint64_t actual = Checksum64(payload.subspan(s.offset, s.size));
    const bool ok = actual == s.checksum;
    if (s.name == "meta") meta_ok = ok;
    if (!ok && problem.empty()) {
      problem = name + ": section " + s.name + ": checksum mismatch (file corrupt)";
    }
    sections.push_back({{"name", s.name},
                        {"offset", s.offset},
                        {"size", s.size},
                        {"checksum", ok ? "ok (xxh3 " + Hex64(actual) + ")"
                                        : "MISMATCH (table " + Hex64(s.checksum) + ", bytes " +
                                              Hex64(actual) + ")"}});
  }
  j["sections"] = sections;

  if (meta_ok) {
    MapCounts c;
    const MapData meta = ParseMapMeta(bytes, name, &c);
    j["counts"] = {{"keyframes", c.keyframes},
                   {"map_points", c.map_points},
                   {"keypoints", c.keypoints},
                   {"observations", c.observations},
                   {"covisibility_edges", c.connections / 2},
                   {"loop_edges", c.loop_edges / 2}};
    const MapVocabulary& v = meta.vocabulary;
    j["vocabulary"] = {{"tree", Hex64(v.content_hash)},
                       {"k", v.k},
                       {"levels", v.levels},
                       {"weighting", v.weighting},
                       {"scoring", v.scoring},
                       {"words", v.num_words},
                       {"name", v.name}};
    const MapCamera& cam = meta.camera;
    j["camera"] = {{"width", cam.width},
                   {"height", cam.height},
                   {"fx", cam.fx},
                   {"fy", cam.fy},
                   {"cx", cam.cx},
                   {"cy", cam.cy},
                   {"distortion", {cam.k1, cam.k2, cam.p1, cam.p2, cam.k3}},
                   {"bf", cam.bf},
                   {"th_depth", cam.th_depth},
                   {"depth_map_factor", cam.depth_map_factor},
                   {"orb_features", cam.orb_features},
                   {"orb_scale_factor", cam.orb_scale_factor},
                   {"orb_levels", cam.orb_levels},
                   {"orb_ini_th_fast", cam.orb_ini_th_fast},
                   {"orb_min_th_fast", cam.orb_min_th_fast}};
    j["bow_levels_up"] = meta.bow_levels_up;
    j["next_keyframe_id"] = meta.next_keyframe_id;
    j["next_map_point_id"] = meta.next_map_point_id;
    if (!meta.metadata.empty()) {
      const auto parsed = nlohmann::ordered_json::parse(meta.metadata, nullptr, false);
      j["metadata"] = parsed.is_discarded() ? nlohmann::ordered_json(meta.metadata) : parsed;
    }
  } else {
    j["counts"] = "unavailable (section meta is corrupt)";
  }
  if (problem.empty()) {
    try {
      const MapData map = ParseMap(bytes, name);
      j["structure"] = "ok";
      if (!map.other_maps.empty()) {
        nlohmann::ordered_json others = nlohmann::ordered_json::array();
        for (const MapData& other : map.other_maps) {
          others.push_back(
              {{"keyframes", other.keyframes.size()}, {"map_points", other.map_points.size()}});
        }
        j["other_maps"] = others;
      }
    } catch (const DataError& e) {
      j["structure"] = e.what();
      problem = e.what();
    }
  } else {
    j["structure"] = "not checked (corrupt sections)";
  }

  std::string text;
  if (options.json) {
    text = DumpJson(j, 2) + "\n";
  } else {
    AppendText(j, "", &text);
  }
  std::cout << text << std::flush;
  if (!problem.empty()) throw DataError(problem);
  return text;
}

// ---------------------------------------------------------------------------
// verify

std::string RunMapVerify(const MapVerifyOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const HeapReservation heap = ReserveHeapForMap(options.map, 1, 0.25);
  const MapData map = ReadMapFile(options.map);
  std::string text = options.map.string() + ": ok (" + std::to_string(map.keyframes.size()) +
                     " keyframes, " + std::to_string(map.map_points.size()) + " map points)";
  for (size_t k = 0; k < map.other_maps.size(); ++k) {
    const MapData& other = map.other_maps[k];
    text += "; other map " + std::to_string(k + 1) +
            " (its own world frame): " + std::to_string(other.keyframes.size()) + " keyframes, " +
            std::to_string(other.map_points.size()) + " map points";
  }
  text += "\n";
  std::cout << text << std::flush;
  return text;
}

// ---------------------------------------------------------------------------
// diff

std::string RunMapDiff(const MapDiffOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const HeapReservation heap = ReserveHeapForMap(options.a, 4, 2);
  const MapData a = ReadMapFile(options.a);
  const MapData b = ReadMapFile(options.b);
  const MapDiff d = DiffMaps(a, b, options.radius);
  char line[256];
  std::string text = "diff " + options.a.string() + " -> " + options.b.string() + " (radius " +
                     nlohmann::json(options.radius).dump() + " m)\n";
  std::snprintf(line, sizeof(line),
                "keyframes: %" PRIu64 " -> %" PRIu64 ": %zu added, %zu removed\n", d.a_keyframes,
                d.b_keyframes, d.added_keyframes.size(), d.removed_keyframes.size());
  text += line;
  std::snprintf(line, sizeof(line),
                "map points: %" PRIu64 " -> %" PRIu64 ": %zu added, %zu removed\n", d.a_map_points,
                d.b_map_points, d.added_points.size(), d.removed_points.size());
  text += line;
  std::cout << text << std::flush;
  if (!options.json_out.empty()) {
    nlohmann::ordered_json j;
    j["a"] = options.a.string();
    j["b"] = options.b.string();
    j["radius_m"] = options.radius;
    j["keyframes"] = {{"a", d.a_keyframes},
                      {"b", d.b_keyframes},
                      {"added_count", d.added_keyframes.size()},
                      {"removed_count", d.removed_keyframes.size()},
                      {"added", d.added_keyframes},
                      {"removed", d.removed_keyframes}};
    j["map_points"] = {{"a", d.a_map_points},
                       {"b", d.b_map_points},
                       {"added_count", d.added_points.size()},
                       {"removed_count", d.removed_points.size()},
                       {"added", PointsJson(d.added_points)},
                       {"removed", PointsJson(d.removed_points)}};
    WriteFileAtomically(options.json_out, DumpJson(j, 2) + "\n");
  }
  return text;
}

// ---------------------------------------------------------------------------
// align-floor

bool MapAlignFloorOptions::Check(std::string* why) const {
  if (stride < 1) {
    *why = "--stride = " + std::to_string(stride) + "; must be >= 1";
    return false;
  }
  return true;
}

std::string RunMapAlignFloor(const MapAlignFloorOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const std::string name = options.map.string();
  MapData map;
  {
    const HeapReservation heap = ReserveHeapForMap(options.map, 1, 0.25);
    map = ReadMapFile(options.map);
  }
  std::optional<RgbdSequence> sequence;
  if (!options.sequence.empty()) sequence = RgbdSequence::Open(options.sequence);
  const std::vector<Eigen::Vector3d> points =
      FloorSearchPoints(map, sequence ? &*sequence : nullptr, options.stride, name);
  const std::optional<Floor> floor = FindFloor(map, points);
  if (!floor) {
    throw AlgorithmError(name + ": no floor found among " + std::to_string(points.size()) +
                         " points (no plane below the cameras within 25 degrees of their up "
                         "direction; the map is unchanged)");
  }
  nlohmann::json metadata = nlohmann::json::parse(map.metadata, nullptr, false);
  if (!metadata.is_object()) metadata = nlohmann::json::object();
  metadata["floor"] = nlohmann::json::parse(FloorToJson(*floor));
  map.metadata = metadata.dump();
  WriteMapFile(options.map, map);
  const Eigen::Vector3d& t = floor->T_floor_map.translation;
  char text[400];
  std::snprintf(text, sizeof(text),
                "%s: floor found: %zu of %zu points within 2 cm, normal %.1f deg from the "
                "cameras' up, cameras %.2f m above it; T_floor_map t = (%.4f, %.4f, %.4f) m "
                "stored in the metadata\n",
                name.c_str(), floor->inliers, floor->points, floor->tilt_deg, floor->camera_height,
                t.x(), t.y(), t.z());
  std::cout << text;
  return text;
}

}  // namespace rrslam
