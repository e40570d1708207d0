#include "stages/eval/compare.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>

#include "common/chart.h"
#include "common/cli.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/path_check.h"
#include "common/text.h"
#include "stages/eval/eval.h"
#include "stages/eval/plot.h"

namespace rrslam {
namespace fs = std::filesystem;
namespace {

constexpr const char* kCsvHeader = "sequence,variant,ate_rmse_cm,change_pct,status,frames,tracked";
constexpr const char* kDefaultChartTitle = "ATE RMSE per sequence";

std::string Fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  return buffer;
}

// Text put in a Markdown table cell: a '|' would end the cell.
std::string Escaped(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
  return out;
}

// A CSV field (RFC 4180): quoted when it holds a comma, a quote or a line break.
std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

// Sequence folders of a column: subfolders (symbolic links followed), without
// hidden ones and AtomicOutput's `*.tmp` temporaries.
std::vector<std::string> SequenceFolders(const CompareColumn& column) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(column.dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name.front() == '.' || name.ends_with(".tmp")) continue;
    std::error_code type_ec;
    if (fs::is_directory(it->path(), type_ec)) names.push_back(name);
  }
  if (ec) {
    throw NoInputError("--column " + column.name + ": " + column.dir.string() +
                       ": cannot list the folder (" + ec.message() + ")");
  }
  return names;
}

// "T of F frames tracked", or "" when run.json did not say.
std::string FramesTracked(const RunSummary& run) {
  if (!run.frames || !run.tracked) return "";
  return std::to_string(*run.tracked) + " of " + std::to_string(*run.frames) + " frames tracked";
}

// Each column's mean ATE RMSE over the rows evaluated in every column.
struct CommonMean {
  std::vector<size_t> rows;
  std::vector<double> rmse_m;                     // Per column.
  std::vector<std::optional<double>> change_pct;  // Per column; nullopt for the baseline.
};

CommonMean MeanOverCommonRows(const CompareTable& table) {
  CommonMean mean;
  const size_t columns = table.columns.size();
  mean.rmse_m.assign(columns, 0.0);
  mean.change_pct.assign(columns, std::nullopt);
  for (size_t r = 0; r < table.cells.size(); ++r) {
    const auto& row = table.cells[r];
    if (!std::all_of(row.begin(), row.end(), [](const CompareCell& c) { return c.evaluated(); })) {
      continue;
    }
    mean.rows.push_back(r);
    for (size_t c = 0; c < columns; ++c) mean.rmse_m[c] += row[c].run->ate_rmse_m;
  }
  if (mean.rows.empty()) return mean;
  for (double& value : mean.rmse_m) value /= static_cast<double>(mean.rows.size());
  const double base = mean.rmse_m[table.baseline];
  for (size_t c = 0; c < columns; ++c) {
    if (c != table.baseline && base > 0) mean.change_pct[c] = (mean.rmse_m[c] - base) / base * 100;
  }
  return mean;
}

// The value of an evaluated cell as the table prints it: "1.23" or "1.23 (-12.5%)".
std::string ValueText(double rmse_m, const std::optional<double>& change_pct) {
  std::string text = Fixed(100 * rmse_m, 2);
  if (change_pct) text += " (" + FormatChangePercent(*change_pct) + ")";
  return text;
}

nlohmann::ordered_json CellToJson(const CompareCell& cell) {
  nlohmann::ordered_json j = {{"status", cell.status()}};
  if (!cell.run) return j;
  const RunSummary& run = *cell.run;
  if (cell.skipped()) {
    j["skipped"] = run.failure;
    return j;
  }
  if (cell.failed()) j["failure"] = run.failure;
  if (run.frames) j["frames"] = *run.frames;
  if (run.tracked) j["tracked"] = *run.tracked;
  if (run.lost) j["lost"] = *run.lost;
  if (cell.evaluated()) {
    j["pairs"] = run.pairs;
    j["ate_m"] = {{"rmse", run.ate_rmse_m}, {"mean", run.ate_mean_m}, {"max", run.ate_max_m}};
  }
  if (cell.change_pct) j["change_pct"] = *cell.change_pct;
  return j;
}

}  // namespace

CompareColumn ParseCompareColumn(const std::string& spec) {
  const size_t equals = spec.find('=');
  if (equals == std::string::npos) {
    throw UsageError("--column '" + spec + "': expected NAME=DIR (e.g. own=runs/own)");
  }
  return {spec.substr(0, equals), spec.substr(equals + 1)};
}

std::string CompareCell::status() const {
  if (!run) return "absent";
  if (run->skipped) return "skipped";
  return run->evaluated ? "evaluated" : "failed";
}

CompareTable ReadCompareTable(const std::vector<CompareColumn>& columns, size_t baseline) {
  if (baseline >= columns.size()) throw UsageError("no baseline column");
  CompareTable table;
  table.columns = columns;
  table.baseline = baseline;
  std::vector<std::set<std::string>> present(columns.size());
  std::set<std::string> sequences;
  for (size_t c = 0; c < columns.size(); ++c) {
    const std::string why = WhyNotAFolder(columns[c].dir);
    if (!why.empty()) {
      throw NoInputError("--column " + columns[c].name + ": " + columns[c].dir.string() + ": " +
                         (why == kPathDoesNotExist ? "no such folder" : why + ", not a folder"));
    }
    for (const std::string& name : SequenceFolders(columns[c])) {
      present[c].insert(name);
      sequences.insert(name);
    }
  }
  if (sequences.empty()) {
    std::string dirs;
    for (const CompareColumn& column : columns) {
      dirs += (dirs.empty() ? "" : ", ") + column.dir.string();
    }
    throw NoInputError("no sequence folder in any column (" + dirs + ")");
  }
  table.sequences.assign(sequences.begin(), sequences.end());  // std::set: sorted.
  for (const std::string& sequence : table.sequences) {
    std::vector<CompareCell> row(columns.size());
    for (size_t c = 0; c < columns.size(); ++c) {
      if (present[c].count(sequence)) row[c].run = ReadRunSummary(columns[c].dir / sequence);
    }
    const CompareCell& base = row[baseline];
    for (size_t c = 0; c < columns.size(); ++c) {
      if (c == baseline || !row[c].evaluated() || !base.evaluated()) continue;
      if (!(base.run->ate_rmse_m > 0)) continue;  // No relative change from zero.
      row[c].change_pct =
          (row[c].run->ate_rmse_m - base.run->ate_rmse_m) / base.run->ate_rmse_m * 100;
    }
    table.cells.push_back(std::move(row));
  }
  return table;
}

std::string FormatChangePercent(double change_pct) {
  std::string text = Fixed(change_pct, 1);
  if (text == "-0.0") text = "0.0";  // A change that rounds to zero has no direction.
  if (text.front() != '-') text = "+" + text;
  return text + "%";
}

std::string FormatCompareTable(const CompareTable& table, const std::string& title) {
  const auto row = [](const std::vector<std::string>& cells) {
    std::string line = "|";
    for (const std::string& cell : cells) line += cell.empty() ? " |" : " " + cell + " |";
    return line + "\n";
  };
  const std::string& base = table.columns[table.baseline].name;
  std::string out;
  if (!title.empty()) out += "**" + title + "**\n\n";
  std::vector<std::string> cells = {"sequence"};
  for (const CompareColumn& column : table.columns) cells.push_back(Escaped(column.name));
  out += row(cells);
  cells.assign(1, "---");
  cells.resize(table.columns.size() + 1, "---:");
  out += row(cells);

  std::vector<std::string> notes;    // Numbered [1], [2], ... in table order.
  std::vector<std::string> unknown;  // Evaluated runs without frame counts.
  size_t evaluated = 0, lost = 0;
  for (size_t r = 0; r < table.sequences.size(); ++r) {
    const std::string& sequence = table.sequences[r];
    cells.assign(1, Escaped(sequence));
    for (size_t c = 0; c < table.columns.size(); ++c) {
      const CompareCell& cell = table.cells[r][c];
      const std::string run_name = table.columns[c].name + "/" + sequence;
      std::string text, note;
      if (cell.evaluated()) {
        ++evaluated;
        text = ValueText(cell.run->ate_rmse_m, cell.change_pct);
        if (cell.lost_frames()) {
          ++lost;
          note = run_name + ": " + FramesTracked(*cell.run) + "; its ATE is over those only";
        } else if (FramesTracked(*cell.run).empty()) {
          unknown.push_back(Escaped(run_name));
        }
      } else if (cell.failed()) {
        text = "failed";
        note = run_name + " failed: " + cell.run->failure;
        const std::string frames = FramesTracked(*cell.run);
        if (!frames.empty()) note += " (" + frames + ")";
      } else if (cell.skipped()) {
        text = "skipped";
        note = run_name + " skipped: " + cell.run->failure;
      }
      if (!note.empty()) {
        notes.push_back(Escaped(note));
        text += " [" + std::to_string(notes.size()) + "]";
      }
      cells.push_back(text);
    }
    out += row(cells);
  }
  const CommonMean mean = MeanOverCommonRows(table);
  if (!mean.rows.empty()) {
    cells.assign(1, "mean of " + std::to_string(mean.rows.size()) + " evaluated" +
                        (table.columns.size() > 1 ? " in every column" : ""));
    for (size_t c = 0; c < table.columns.size(); ++c) {
      cells.push_back(ValueText(mean.rmse_m[c], mean.change_pct[c]));
    }
    out += row(cells);
  }

  out += "\nATE RMSE in cm";
  if (table.columns.size() > 1) {
    out += "; in parentheses the change against " + Escaped(base) + ", (variant - " +
           Escaped(base) + ") / " + Escaped(base);
  }
  out += ".";
  if (evaluated > lost + unknown.size()) {  // Some run is known to have tracked every frame.
    out += std::string(" Every") + (lost > 0 ? " other" : "") + " evaluated run" +
           (unknown.empty() ? "" : " with a run.json") + " tracked all of its frames.";
  }
  out += "\n";
  if (!notes.empty() || !unknown.empty()) out += "\n";
  for (size_t k = 0; k < notes.size(); ++k) {
    out += "- [" + std::to_string(k + 1) + "] " + notes[k] + "\n";
  }
  if (!unknown.empty()) {
    out += "- frames tracked unknown (no run.json):";
    for (size_t k = 0; k < unknown.size(); ++k) out += (k == 0 ? " " : ", ") + unknown[k];
    out += "\n";
  }
  return out;
}

std::string FormatCompareCsv(const CompareTable& table) {
  std::string out = std::string(kCsvHeader) + "\n";
  for (size_t r = 0; r < table.sequences.size(); ++r) {
    for (size_t c = 0; c < table.columns.size(); ++c) {
      const CompareCell& cell = table.cells[r][c];
      std::string line = CsvField(table.sequences[r]) + "," + CsvField(table.columns[c].name) + ",";
      if (cell.evaluated()) line += Fixed(100 * cell.run->ate_rmse_m, 4);
      line += ",";
      if (cell.change_pct) line += Fixed(*cell.change_pct, 2);
      line += ',';  // Appended piecewise: "," + std::string trips GCC 12's -Wrestrict.
      line += cell.status();
      line += ',';
      if (cell.run && !cell.skipped() && cell.run->frames)
        line += std::to_string(*cell.run->frames);
      line += ",";
      if (cell.run && !cell.skipped() && cell.run->tracked) {
        line += std::to_string(*cell.run->tracked);
      }
      out += line + "\n";
    }
  }
  return out;
}

nlohmann::ordered_json CompareToJson(const CompareTable& table,
                                     const nlohmann::ordered_json& options) {
  nlohmann::ordered_json json = {{"producer", Producer("eval")}, {"command", "compare"}};
  if (!options.is_null()) json["options"] = options;
  nlohmann::ordered_json columns = nlohmann::ordered_json::array();
  for (size_t c = 0; c < table.columns.size(); ++c) {
    columns.push_back({{"name", table.columns[c].name},
                       {"dir", table.columns[c].dir.string()},
                       {"baseline", c == table.baseline}});
  }
  json["columns"] = columns;
  json["baseline"] = table.columns[table.baseline].name;
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (size_t r = 0; r < table.sequences.size(); ++r) {
    nlohmann::ordered_json cells = nlohmann::ordered_json::object();
    for (size_t c = 0; c < table.columns.size(); ++c) {
      cells[table.columns[c].name] = CellToJson(table.cells[r][c]);
    }
    rows.push_back({{"sequence", table.sequences[r]}, {"cells", cells}});
  }
  json["sequences"] = rows;
  const CommonMean mean = MeanOverCommonRows(table);
  nlohmann::ordered_json mean_json = {{"sequences", nlohmann::ordered_json::array()}};
  for (const size_t r : mean.rows) mean_json["sequences"].push_back(table.sequences[r]);
  if (!mean.rows.empty()) {
    nlohmann::ordered_json rmse = nlohmann::ordered_json::object();
    nlohmann::ordered_json change = nlohmann::ordered_json::object();
    for (size_t c = 0; c < table.columns.size(); ++c) {
      rmse[table.columns[c].name] = mean.rmse_m[c];
      if (mean.change_pct[c]) change[table.columns[c].name] = *mean.change_pct[c];
    }
    mean_json["ate_rmse_m"] = rmse;
    mean_json["change_pct"] = change;
  }
  json["mean"] = mean_json;
  return json;
}

bool CompareChartOptions::Check(std::string* why) const {
  return chart::CheckChartSize(width_px, height_px, "plot", why);
}

nlohmann::ordered_json CompareChartOptions::ToJson() const {
  return {{"width_px", width_px}, {"height_px", height_px}};
}

cv::Scalar CompareColumnColour(size_t index) {
  // matplotlib's tab10, BGR: blue, orange, green, red, purple, brown, pink,
  // grey, olive, cyan. Familiar from papers' figures, and distinguishable.
  static const std::array<cv::Scalar, 10> kPalette = {
      cv::Scalar(180, 119, 31),  cv::Scalar(14, 127, 255),  cv::Scalar(44, 160, 44),
      cv::Scalar(40, 39, 214),   cv::Scalar(189, 103, 148), cv::Scalar(75, 86, 140),
      cv::Scalar(194, 119, 227), cv::Scalar(127, 127, 127), cv::Scalar(34, 189, 188),
      cv::Scalar(207, 190, 23)};
  return kPalette[index % kPalette.size()];
}

cv::Mat RenderCompareChart(const CompareTable& table, const CompareChartOptions& options,
                           const std::string& title) {
  using namespace chart;
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const size_t n_rows = table.sequences.size(), n_columns = table.columns.size();
  bool any_failed = false, any_skipped = false, any_lost = false;
  double max_cm = 0;
  std::string largest;  // "<variant>/<sequence>" of the largest RMSE.
  for (size_t r = 0; r < table.cells.size(); ++r) {
    for (size_t c = 0; c < table.cells[r].size(); ++c) {
      const CompareCell& cell = table.cells[r][c];
      any_failed |= cell.failed();
      any_skipped |= cell.skipped();
      any_lost |= cell.evaluated() && cell.lost_frames();
      if (cell.evaluated() && 100 * cell.run->ate_rmse_m > max_cm) {
        max_cm = 100 * cell.run->ate_rmse_m;
        largest = table.columns[c].name + "/" + table.sequences[r];
      }
    }
  }
  const bool footer = any_failed || any_skipped || any_lost;
  cv::Mat image(options.height_px, options.width_px, CV_8UC3, kBackground);
  const ChartLayout layout = MakeLayout(image.size(), footer);
  const cv::Rect& area = layout.area;
  const int text_height = layout.text_height;

  // Vertical scale: from 0, with room above the tallest bar for its value
  // and for the legend (DrawLegend's box: rows of 2 text heights and a
  // padding of 0.9), so that neither hides a bar. With many columns the
  // legend may need more than half the height; then it may cover bars.
  const double legend_height = text_height * (2.0 * n_columns - 1 + 2 * 0.9 + 0.9);
  const double headroom_px = std::min(legend_height + 2.0 * text_height, 0.5 * area.height);
  if (!(max_cm > 0)) max_cm = 1;  // Nothing evaluated (or all zero): an axis to 1 cm.
  const double v_top = max_cm * area.height / (area.height - headroom_px);
  if (!std::isfinite(v_top)) {
    // ReadRunSummary refuses RMSEs that are not finite; one near DBL_MAX
    // metres still overflows in centimetres, past what an axis can show.
    throw DataError("compare chart: the ATE RMSE of " + largest +
                    " is too large to chart (its centimetres overflow a double)");
  }
  Axes2d axes;
  axes.centre_u = n_rows / 2.0;  // Group i spans u in [i, i + 1].
  axes.centre_v = v_top / 2;
  axes.pixels_per_u = area.width / static_cast<double>(n_rows);
  axes.pixels_per_v = area.height / v_top;
  axes.centre_px = cv::Point2d(area.x + area.width / 2.0, area.y + area.height / 2.0);

  // Horizontal grid, ticks and labels about 110 px apart (as DrawGrid, which
  // would also label the categorical u axis with numbers).
  const double step = NiceStep(110.0 * layout.ui / axes.pixels_per_v);
  for (const double v : TickValues(0, v_top + 1e-9 * step, step)) {
    const double y = axes(Eigen::Vector2d(0, v)).y;
    cv::line(image, SubPixel({double(area.x), y}), SubPixel({double(area.br().x), y}), kGrid, 1,
             cv::LINE_AA, kShift);
    cv::line(image, SubPixel({double(area.x - layout.tick), y}), SubPixel({double(area.x), y}),
             kFrame, 1, cv::LINE_AA, kShift);
    PutText(image, TickLabel(v, step), {area.x - layout.tick - 0.6 * text_height, y}, layout.font,
            1, 1, 0.5);
  }

  // Bars: each group fills 80% of its slot; bars are 1 px apart when wide enough.
  const double bar_u = 0.8 / static_cast<double>(n_columns);
  const double bar_px = bar_u * axes.pixels_per_u;
  const int gap = bar_px >= 6 ? 1 : 0;
  const double base_y = axes(Eigen::Vector2d(0, 0)).y;
  // Value labels share one font scale, the largest (up to the tick font) at
  // which the widest fits its bar's slot; where even the smallest legible
  // font (0.3) would spill over the neighbours, values are left to the table
  // and only the '*' of a run that lost frames stays.
  int baseline = 0;
  const double widest_value =
      cv::getTextSize(Fixed(max_cm, 2) + "*", kFont, 1.0, 1, &baseline).width;
  const double value_font = std::clamp(0.98 * bar_px / widest_value, 0.3, layout.font);
  const bool show_values = value_font * widest_value <= 1.1 * bar_px;
  std::vector<cv::Point2d> occupied;  // Image pixels of bars and labels, for the legend.
  for (size_t r = 0; r < n_rows; ++r) {
    for (size_t c = 0; c < n_columns; ++c) {
      const CompareCell& cell = table.cells[r][c];
      const double u0 = r + 0.1 + c * bar_u;
      const double x0 = axes(Eigen::Vector2d(u0, 0)).x, x1 = x0 + bar_px;
      const double centre_x = 0.5 * (x0 + x1);
      const cv::Scalar colour = CompareColumnColour(c);
      if (cell.evaluated()) {
        const double cm = 100 * cell.run->ate_rmse_m;
        const double top_y = axes(Eigen::Vector2d(0, cm)).y;
        const cv::Rect bar(cv::Point(static_cast<int>(std::lround(x0)) + gap,
                                     static_cast<int>(std::lround(top_y))),
                           cv::Point(static_cast<int>(std::lround(x1)) - gap,
                                     static_cast<int>(std::lround(base_y))));
        cv::rectangle(image, bar, colour, cv::FILLED, cv::LINE_8);
        const std::string label =
            (show_values ? Fixed(cm, 2) : "") + (cell.lost_frames() ? "*" : "");
        const double label_y = top_y - 0.5 * text_height;
        PutText(image, label, {centre_x, label_y}, value_font, 1, 0.5, 1);
        // Counted, not stepped: y += 0.5 * text_height stalls on huge y.
        const double first_y = std::max(label_y - text_height, 0.0);
        const int points = std::isfinite(first_y) && first_y <= base_y
                               ? static_cast<int>((base_y - first_y) / (0.5 * text_height)) + 1
                               : 0;
        for (int k = 0; k < points; ++k)
          occupied.emplace_back(centre_x, first_y + 0.5 * text_height * k);
      } else if (cell.failed() || cell.skipped()) {
        // A cross (failed) or a dash (skipped) on the axis, in the column's colour.
        const double half = std::clamp(0.35 * bar_px, 2.0, 0.7 * text_height);
        const cv::Point2d centre(centre_x, base_y - half - 0.5 * text_height);
        const int thickness = std::max(2, layout.line_width);
        if (cell.failed()) {
          cv::line(image, SubPixel(centre + cv::Point2d(-half, -half)),
                   SubPixel(centre + cv::Point2d(half, half)), colour, thickness, cv::LINE_AA,
                   kShift);
          cv::line(image, SubPixel(centre + cv::Point2d(-half, half)),
                   SubPixel(centre + cv::Point2d(half, -half)), colour, thickness, cv::LINE_AA,
                   kShift);
        } else {
          cv::line(image, SubPixel(centre + cv::Point2d(-half, 0)),
                   SubPixel(centre + cv::Point2d(half, 0)), colour, thickness, cv::LINE_AA, kShift);
        }
        occupied.emplace_back(centre_x, base_y - text_height);
      }
    }
  }

  // Sequence names under their groups, TUM's long folder names shortened
  // (rgbd_dataset_freiburg1_desk: fr1_desk, CanonicalSequenceName): one row
  // when they fit, else alternately on two rows; then a smaller font, then
  // cut short with "..". A label is kept inside the image.
  const double slot_px = axes.pixels_per_u;
  std::vector<std::string> names;
  double widest_name = 1;
  for (const std::string& sequence : table.sequences) {
    names.push_back(CanonicalSequenceName(sequence));
    widest_name = std::max<double>(widest_name,
                                   cv::getTextSize(names.back(), kFont, 1.0, 1, &baseline).width);
  }
  const bool two_rows = widest_name * layout.font > 0.95 * slot_px && n_rows > 1;
  const double room_px = (two_rows ? 1.9 : 0.95) * slot_px;
  const double name_font = std::clamp(room_px / widest_name, 0.3, layout.font);
  for (size_t r = 0; r < n_rows; ++r) {
    std::string& name = names[r];
    while (name.size() > 3 &&
           cv::getTextSize(name, kFont, name_font, 1, &baseline).width > room_px) {
      name = name.substr(0, name.size() - 3) + "..";
    }
    const double x = axes(Eigen::Vector2d(r + 0.5, 0)).x;
    const double half_width = cv::getTextSize(name, kFont, name_font, 1, &baseline).width / 2.0;
    const double label_x = std::clamp(x, half_width + 2, image.cols - half_width - 2);
    const double y = area.br().y + layout.tick + (two_rows && r % 2 ? 2.3 : 0.6) * text_height;
    PutText(image, name, {label_x, y}, name_font, 1, 0.5, 0);
    cv::line(image, SubPixel({x, double(area.br().y)}),
             SubPixel({x, double(area.br().y + layout.tick)}), kFrame, 1, cv::LINE_AA, kShift);
  }

  DrawFrameAndLabels(image, layout, "", "ATE RMSE [cm]",
                     title.empty() ? kDefaultChartTitle : title);
  std::vector<LegendEntry> entries;
  const int swatch = std::max(layout.line_width, static_cast<int>(std::lround(0.8 * text_height)));
  for (size_t c = 0; c < n_columns; ++c) {
    entries.push_back({table.columns[c].name, CompareColumnColour(c), swatch});
  }
  DrawLegend(image, layout, entries, occupied);
  if (footer) {
    std::string text;
    if (any_failed) text += "x failed";
    if (any_skipped) text += std::string(text.empty() ? "" : "    ") + "- skipped";
    if (any_lost) {
      text += std::string(text.empty() ? "" : "    ") +
              "* lost frames: ATE over the tracked frames only";
    }
    const double width = cv::getTextSize(text, kFont, 1.0, 1, &baseline).width;
    const double font = std::clamp((image.cols - area.x - 4) / width, 0.3, layout.font);
    PutText(image, text, {double(area.x), double(layout.footer_y)}, font, 1, 0, 0.5);
  }
  return image;
}

bool EvalCompareOptions::Check(std::string* why) const {
  if (columns.empty()) {
    *why = "give at least one --column NAME=DIR";
    return false;
  }
  std::set<std::string> names;
  for (const CompareColumn& column : columns) {
    if (column.name.empty()) {
      *why = "--column '=" + column.dir.string() + "': empty NAME; expected NAME=DIR";
      return false;
    }
    if (column.name.find_first_of("|\r\n") != std::string::npos) {
      *why = "--column name '" + column.name + "' must not hold '|' or line breaks";
      return false;
    }
    if (column.dir.empty()) {
      *why = "--column '" + column.name + "=': empty DIR; expected NAME=DIR";
      return false;
    }
    if (!names.insert(column.name).second) {
      *why = "--column name '" + column.name + "' is given twice";
      return false;
    }
  }
  if (!baseline.empty() && !names.count(baseline)) {
    std::string list;
    for (const CompareColumn& column : columns) list += (list.empty() ? "" : ", ") + column.name;
    *why = "--baseline '" + baseline + "' is not a column name (" + list + ")";
    return false;
  }
  if (!plot.Check(why)) return false;
  if (!plot_path.empty() && AsciiLowercase(plot_path.extension().string()) != ".png") {
    *why = "plot " + plot_path.string() + " must be a .png file";
    return false;
  }
  std::vector<NamedPath> inputs;
  for (const CompareColumn& column : columns)
    inputs.emplace_back("--column " + column.name, column.dir);
  return CheckOutputs({{"--out", out}, {"--csv", csv_path}, {"--plot", plot_path}}, inputs, why);
}

size_t EvalCompareOptions::BaselineIndex() const {
  for (size_t c = 0; c < columns.size(); ++c) {
    if (columns[c].name == baseline) return c;
  }
  return 0;
}

nlohmann::ordered_json EvalCompareOptions::ToJson() const {
  nlohmann::ordered_json column_json = nlohmann::ordered_json::array();
  for (const CompareColumn& column : columns) {
    column_json.push_back({{"name", column.name}, {"dir", column.dir.string()}});
  }
  nlohmann::ordered_json j = {
      {"columns", column_json},
      {"baseline", columns.empty() ? baseline : columns[BaselineIndex()].name},
      {"title", title},
      {"json", json},
      {"out", out.string()},
      {"csv", csv_path.string()},
      {"plot", plot_path.string()}};
  if (!plot_path.empty()) j["plot_options"] = plot.ToJson();
  return j;
}

CompareTable RunEvalCompare(const EvalCompareOptions& options, std::ostream& out) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const CompareTable table = ReadCompareTable(options.columns, options.BaselineIndex());
  spdlog::info("{} sequences x {} variants, baseline {}", table.sequences.size(),
               table.columns.size(), table.columns[table.baseline].name);
  const nlohmann::ordered_json options_json = options.ToJson();
  std::string report;
  if (options.json) {
    nlohmann::ordered_json report_options = options_json;
    report_options.erase("columns");  // The report lists them as its inputs.
    report = DumpJson(CompareToJson(table, report_options), 2) + "\n";
  } else {
    report = FormatCompareTable(table, options.title);
  }
  std::vector<std::pair<fs::path, std::string>> files;
  if (!options.csv_path.empty()) files.emplace_back(options.csv_path, FormatCompareCsv(table));
  if (!options.plot_path.empty()) {
    const std::vector<uint8_t> png = EncodePng(
        RenderCompareChart(table, options.plot, options.title), kPlotPngCompression,
        {{"Software", Producer("eval")},
         {"Comment",
          DumpJson(nlohmann::ordered_json{{"command", "compare"}, {"options", options_json}})}});
    files.emplace_back(options.plot_path, std::string(png.begin(), png.end()));
  }
  if (!options.out.empty()) files.emplace_back(options.out, report);
  WriteOutputFiles(std::move(files));
  if (options.out.empty()) {
    out << report;
    out.flush();
  }
  return table;
}

}  // namespace rrslam
